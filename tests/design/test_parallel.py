from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from bayescal.design.parallel import seeded_map


def noisy_sum(item: int, rng: np.random.Generator, *, scale: float) -> float:
    return item + scale * float(rng.normal())


def test_results_depend_on_the_seed_only_not_on_the_workers():
    serial = seeded_map(noisy_sum, range(6), 7, executor=ThreadPoolExecutor(max_workers=1), scale=0.5)
    parallel = seeded_map(noisy_sum, range(6), 7, executor=ThreadPoolExecutor(max_workers=3), scale=0.5)
    pooled = seeded_map(noisy_sum, range(6), 7, scale=0.5)
    assert serial == parallel == pooled
    assert seeded_map(noisy_sum, range(6), 8, executor=ThreadPoolExecutor(), scale=0.5) != serial


def test_each_item_gets_its_own_stream_in_order():
    draws = seeded_map(noisy_sum, [0, 0, 0], 1, executor=ThreadPoolExecutor(), scale=1.0)
    assert len(set(draws)) == 3
    first_two = seeded_map(noisy_sum, [0, 0], 1, executor=ThreadPoolExecutor(), scale=1.0)
    assert first_two == draws[:2]


@pytest.fixture(scope="module")
def dask_executor():
    """A ``concurrent.futures`` executor on a local dask.distributed cluster of two worker processes."""
    distributed = pytest.importorskip("distributed", reason="the cluster extra (dask[distributed]) is not installed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            yield client.get_executor()


def test_a_study_on_a_dask_cluster_gives_the_process_pools_table(data_dir, dask_executor):
    """A plan study run on a local dask.distributed cluster (worker processes) equals the process pool's, seed for seed."""
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal_studies.studies.plans import simulate_plan

    cell = load_cell(data_dir / "kr270.toml")
    plan = read_plan(data_dir / "table3_plan.csv", cell.robot)
    with ProcessPoolExecutor(max_workers=2) as pool:
        pooled = simulate_plan(cell, plan, campaigns=4, seed=3, executor=pool)
    clustered = simulate_plan(cell, plan, campaigns=4, seed=3, executor=dask_executor)
    np.testing.assert_array_equal(clustered["errors"], pooled["errors"])
    np.testing.assert_array_equal(clustered["parameter_errors"], pooled["parameter_errors"])


def test_the_q2_angle_study_on_a_dask_cluster_gives_the_serial_table(data_dir, dask_executor):
    """The designer and its candidate set travel to the cluster's workers; the table is the serial one, seed for seed."""
    from bayescal.cell.config import load_cell
    from bayescal.design.angles import q2_angle_study

    cell = load_cell(data_dir / "kr270.toml")
    options = dict(angles=[3, 4], per_angle=[1, 2], candidates_per_angle=2, seed=5)
    with ThreadPoolExecutor(max_workers=1) as serial:
        expected = q2_angle_study(cell, executor=serial, **options)
    pd.testing.assert_frame_equal(q2_angle_study(cell, executor=dask_executor, **options), expected)
