"""The registration on sweeps with a real cell's error budget (bayescal.twin.independent.cell_sweeps).

Fast tests on a few files; the slow ones repeat the studies of docs/registration.md (100 files for the labels, 300 for
the coverage).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.registration.axes import LABEL_GAIN
from bayescal.registration.register import register
from bayescal.registration.robust import interval_factor
from bayescal_studies.studies.registration_budget import HOME_DEG, _as_sweeps, coverage, coverage_study, label_study
from bayescal.twin.independent.cell_sweeps import cell_sweeps, swap_labels


def _serial():
    """One worker: the studies' files one after another (the tests share the machine's cores)."""
    return ThreadPoolExecutor(1)


def test_generated_files_carry_the_budget_and_the_truth(cell):
    generated = cell_sweeps(cell, np.random.default_rng(3), home_deg=HOME_DEG, noise_factor=5.0)
    table = generated.table
    assert set(table["joint"]) == {1, 2} and set(table["marker"]) == {"S1", "S2", "S3"}
    # Readings dropped at some angles, never below four angles per reflector and joint.
    assert len(table) < 2 * 7 * 3
    assert table.groupby(["joint", "marker"]).size().min() >= 4
    assert generated.noise_factor == 5.0 and set(generated.axes) == {0, 1}
    swapped = swap_labels(table, 0, np.random.default_rng(1))
    changed = swapped["marker"] != table["marker"]
    assert changed.sum() == 2 and set(swapped.loc[changed, "joint"]) == {1}


def test_a_swap_is_caught_and_honest_scatter_is_not_on_a_few_files(cell):
    with _serial() as executor:
        honest = label_study(cell, 6, seed=5, executor=executor)
        loose = label_study(cell, 6, seed=6, loose=5.0, executor=executor)
    for table in (honest, loose):
        assert (table["swapped_nats"] > LABEL_GAIN).all(), table
        assert (table["honest_nats"] <= LABEL_GAIN).all(), table


def test_intervals_cover_on_a_few_files(cell):
    with _serial() as executor:
        table = coverage_study(cell, 6, seed=5, draws=200, executor=executor)
    assert table.filter(like="excess").min().min() > 2.0  # noise 3-10 times the law, learned
    z, dof = table.filter(like="z_").to_numpy(), table.filter(like="dof_").to_numpy()
    assert np.all(np.abs(z) < interval_factor(4.0, dof))


def test_seven_angles_give_student_t_intervals_in_the_output(cell):
    # Seven angles a sweep: the sds' degrees of freedom are few (measured 2.6-3.2 for the axes, 3.9-7.2 for the base
    # frame's components on this file), so the interval with the normal's ±3 sd coverage is 8.6-11.6 sd wide for the
    # axes and 4.5-6.8 sd for the frame, and the output says so; the normal's ±3 sd would be 3.
    generated = cell_sweeps(cell, np.random.default_rng(5), home_deg=HOME_DEG, noise_factor=5.0)
    payload = register(_as_sweeps(generated.table), cell, rng=0, draws=200).to_json()
    for axis in payload["axes"].values():
        assert 2.0 < axis["direction_dof"] < 5.0 and 2.0 < axis["point_dof"] < 5.0
        assert axis["half_width"]["direction_mrad"]["3"] > 6.0 * axis["direction_sd_mrad"]
        assert axis["half_width"]["point_mm"]["3"] > 6.0 * axis["point_sd_mm"]
        assert "Student's t" in axis["interval"]
    base = payload["frames"]["base"]
    for key, unit in (("rotation", "mrad"), ("translation", "mm")):
        factors = np.array(base[f"{key}_half_width_{unit}"]["3"]) / np.array(base[f"{key}_sd_{unit}"])
        assert np.allclose(factors, interval_factor(3.0, np.array(base[f"{key}_dof"], dtype=float)))
        assert np.all(factors > 4.0)


@pytest.mark.slow
@pytest.mark.parametrize("loose", [1.0, 5.0])
def test_a_swap_is_caught_and_honest_scatter_is_not_in_95_percent_of_100_files(cell, loose):
    with _serial() as executor:
        table = label_study(cell, 100, seed=2026, loose=loose, executor=executor)
    assert np.mean(table["swapped_nats"] > LABEL_GAIN) >= 0.95
    assert np.mean(table["honest_nats"] <= LABEL_GAIN) >= 0.95


@pytest.mark.slow
def test_axes_and_base_frame_cover_nominally_over_300_files_at_noise_3_to_10_times_the_law(cell):
    # Seed 4711 was not looked at while the rule was chosen (on seed 2026).  Measured 68.3 / 95.9 / 99.8 % of all
    # components within their Student-t intervals with the normal's ±1/2/3 sd coverage (the base frame's translation,
    # the lowest, 66.0 / 95.2 / 99.8 %); with the normal's ±1/2/3 sd on the same sds 61.0 / 88.2 / 96.3 %.  On seed
    # 2026 the rule before (the sandwich floored at the excess-scaled Laplace covariance) covered 70.0 / 94.1 / 99.0 %.
    with _serial() as executor:
        table = coverage_study(cell, 300, seed=4711, executor=executor)
    for group in ("direction", "point", "rotation", "translation", ""):
        shares = coverage(table, group)
        for k, share in shares.items():
            nominal = 2 * norm.cdf(k) - 1
            # Components of one file are correlated: the binomial sd over the 300 files, 3 sd allowed.
            assert abs(share - nominal) < 3 * np.sqrt(nominal * (1 - nominal) / 300), (group, k, share)
