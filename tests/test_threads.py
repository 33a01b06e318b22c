import ast
import os
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from bayescal.sampling.collapsed import CollapsedSampler
from bayescal.threads import one_blas_thread

ROOT = str(Path(__file__).resolve().parents[1])


def _blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


@pytest.fixture
def two_blas_threads():
    """BLAS at two threads, as OpenBLAS starts on a two-core machine (the tests' conftest sets one)."""
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl controls")
    with threadpool_limits(2, user_api="blas"):
        if max(_blas_threads()) < 2:
            pytest.skip("this BLAS runs one thread at most")
        yield


def test_one_thread_inside_and_the_users_setting_after(two_blas_threads):
    before = _blas_threads()
    with one_blas_thread():
        assert set(_blas_threads()) == {1}
        with one_blas_thread():
            assert set(_blas_threads()) == {1}
        # Leaving the inner block must not lift the outer one's limit.
        assert set(_blas_threads()) == {1}
    assert _blas_threads() == before


def test_the_limit_is_lifted_when_the_block_raises(two_blas_threads):
    before = _blas_threads()
    with pytest.raises(ZeroDivisionError), one_blas_thread():
        1 / 0
    assert _blas_threads() == before


def test_a_block_in_another_thread_leaves_blas_as_it_is(two_blas_threads):
    """OpenBLAS ignores a size set from another thread once the main thread set one: such a block does not try."""
    before = _blas_threads()
    seen = []

    def other():
        with one_blas_thread():
            seen.append(_blas_threads())

    worker = threading.Thread(target=other)
    worker.start()
    worker.join(timeout=30)
    assert seen == [before]
    assert _blas_threads() == before


def test_a_library_imported_after_a_block_is_limited_by_the_next_block():
    """scipy.linalg brings its own OpenBLAS: a block entered after its import limits it too (a fresh process)."""
    script = """
import numpy
from threadpoolctl import threadpool_info, threadpool_limits
from bayescal.threads import one_blas_thread
with one_blas_thread():
    pass
import scipy.linalg
with threadpool_limits(2, user_api="blas"), one_blas_thread():
    print(sorted((pool["filepath"], pool["num_threads"]) for pool in threadpool_info() if pool["user_api"] == "blas"))
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, env=os.environ | {"PYTHONPATH": ROOT})
    pools = ast.literal_eval(done.stdout)
    if len(pools) < 2:
        pytest.skip("scipy.linalg shares NumPy's BLAS here")
    assert {threads for _, threads in pools} == {1}


class _Recording:
    """A sampler (the protocol's ``sample``) that notes BLAS's threads when a fit calls it, then samples."""

    def __init__(self, sampler):
        self.sampler, self.threads = sampler, []

    def __getattr__(self, name):
        return getattr(self.sampler, name)

    def sample(self, target, start, scale, rng):
        self.threads.append(set(_blas_threads()))
        return self.sampler.sample(target, start, scale, rng)


def test_the_fits_run_on_one_blas_thread_and_leave_the_setting_alone(two_blas_threads, cell, campaign_csv, data_dir):
    from bayescal.cell.campaign import read_campaign
    from bayescal.geometry.arcs import read_arc_points
    from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
    from bayescal.inference.elastostatic import ElastostaticModel

    before = _blas_threads()
    geometry = _Recording(geometry_sampler(n_chains=2, n_tune=50, n_draws=50))
    elastostatic = _Recording(CollapsedSampler(n_chains=2, n_draws=50, n_adapt=200, pilot_chains=4, pilot_sweeps=5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        GeometryPosteriorModel(sampler=geometry).fit(read_arc_points(data_dir / "table1_geometry.csv"), 0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ElastostaticModel.from_cell(cell, sampler=elastostatic).fit(read_campaign(campaign_csv, cell=cell), 0)
    assert geometry.threads == [{1}] and elastostatic.threads and all(t == {1} for t in elastostatic.threads)
    assert _blas_threads() == before
    # The elastostatic fit's warnings (K_c not identifiable from one repeat, short chains) still name the caller's line.
    assert caught and {Path(w.filename).name for w in caught} == {Path(__file__).name}
