"""Coverage of the elastostatic intervals on twin campaigns unlike the config (studies.elastostatic_coverage)."""

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from scipy import stats

from bayescal.sampling.gibbs import GibbsSampler
from bayescal.cell.config import load_cell
from bayescal_studies.studies.elastostatic_coverage import Truth, TruthSpread, elastostatic_coverage, fit_against_truth, random_plan
from bayescal.units import MM, N_PER_MM

LEVELS = np.array([1.0, 2.0, 3.0])
NOMINAL = 2 * stats.norm.cdf(LEVELS) - 1  # 0.6827, 0.9545, 0.9973


def hits(table) -> np.ndarray:
    """(checks, 3): whether each truth lies within ±1, 2, 3 posterior sd of the mean."""
    return np.abs(table["z"].to_numpy())[:, None] <= LEVELS[None, :]


def test_random_plans_spread_q2_over_the_joint_range(cell):
    plan = random_plan(cell, 6, 5, np.random.default_rng(0))
    q2 = np.unique(plan.q[:, 1])
    assert plan.q.shape == (30, 6) and q2.size == 6
    assert np.all((plan.q >= cell.robot.lower) & (plan.q <= cell.robot.upper))
    assert np.ptp(q2) > 0.5 * (cell.robot.upper[1] - cell.robot.lower[1])


def test_truths_are_drawn_within_their_spread_of_the_cells_values(cell, data_dir):
    spread = TruthSpread(compliances=0.1, K_c=0.3, s0=0.05, masses=0.15)
    truths = [spread.draw(cell, np.random.default_rng(seed)) for seed in range(20)]
    ratios = np.array([t.compliances / cell.compliances for t in truths])
    assert np.all(np.abs(ratios - 1) <= 0.1) and np.ptp(ratios) > 0.1
    assert all(abs(t.spring[0] / cell.compensator.K_c - 1) <= 0.3 and abs(t.spring[1] / cell.compensator.s0 - 1) <= 0.05 for t in truths)
    assert all(abs(t.masses - 1) <= 0.15 for t in truths) and len({t.masses for t in truths}) == 20
    # the same generator state gives the same truth; a robot without a compensator gets no spring
    np.testing.assert_array_equal(spread.draw(cell, np.random.default_rng(3)).compliances, truths[3].compliances)
    assert spread.draw(load_cell(data_dir / "robots" / "arm6.toml"), np.random.default_rng(0)).spring is None


def test_intervals_are_not_grossly_miscalibrated_on_ten_campaigns(cell):
    sampler = GibbsSampler(n_chains=2, n_tune=150, n_draws=300)
    table = elastostatic_coverage(cell, 10, 5, sampler=sampler, angles=5, per_angle=3, executor=ThreadPoolExecutor(2))
    assert set(table["parameter"]) >= {"k2", "k3", "k4", "k5", "k6", "K_c", "s0", "gravity_scale"}
    counted = hits(table[table["identifiable"]])
    n = counted.shape[0]
    # Checks within one campaign are correlated: only a gross miscalibration (sds off by 1.5) should fail this.
    low, high = stats.binom.ppf(0.0005, n, NOMINAL), stats.binom.ppf(0.9995, n, NOMINAL)
    assert np.all((low <= counted.sum(axis=0)) & (counted.sum(axis=0) <= high)), (counted.sum(axis=0), low, high)


@pytest.mark.slow
def test_intervals_cover_at_nominal_rates_on_200_campaigns(cell):
    # Parameters flagged not identifiable are counted apart: their intervals reflect the prior.
    table = elastostatic_coverage(cell, 200, 21)
    group = table[table["identifiable"]]
    rates = hits(group).mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(group)) + 1.0 / len(group)
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL, tolerance)


@pytest.mark.slow
def test_intervals_cover_with_the_cells_distance_dependent_noise(cell):
    table = elastostatic_coverage(cell, 60, 22, noise_um=None)
    group = table[table["identifiable"]]
    rates = hits(group).mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(group)) + 1.0 / len(group)
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL, tolerance)


def test_a_spring_unlike_the_configs_is_found_from_near_noise_free_data(cell):
    # the config says K_c = 144 N/mm and s0 = 458 mm; the twin's spring is 660 N/mm and 575 mm
    truth = Truth(cell.compliances, (660.0 * N_PER_MM, 575.0 * MM))
    rows = {row["parameter"]: row for row in fit_against_truth(cell, truth, np.random.default_rng(0), noise_um=0.3)}
    for name in ("K_c", "s0"):
        assert rows[name]["identifiable"] and abs(rows[name]["z"]) < 3.5, rows[name]
    assert rows["K_c"]["sd"] < 0.01 * 660.0


def test_random_plans_of_an_any_direction_cell_push_every_way(data_dir):
    from bayescal.cell.config import load_cell

    any_cell = load_cell(data_dir / "kr270_any_load.toml")
    plan = random_plan(any_cell, 5, 3, np.random.default_rng(2))
    np.testing.assert_allclose(np.linalg.norm(plan.force, axis=1), 2750.0)
    assert np.hypot(plan.force[:, 0], plan.force[:, 1]).max() > 1000.0
    assert plan.couple.shape == (15, 3)


def _k1_coverage(data_dir, campaigns, seed, sampler=None):
    from bayescal.cell.config import load_cell

    any_cell = load_cell(data_dir / "kr270_any_load.toml")
    table = elastostatic_coverage(any_cell, campaigns, seed, sampler=sampler, angles=5, per_angle=3, executor=ThreadPoolExecutor(2))
    return table[table["parameter"] == "k1"]


def test_k1_is_identified_from_loads_in_any_direction_on_six_campaigns(data_dir):
    k1 = _k1_coverage(data_dir, 6, 7, GibbsSampler(n_chains=2, n_tune=150, n_draws=300))
    assert len(k1) == 6 and k1["identifiable"].all()
    assert (k1["z"].abs() <= 3.0).sum() >= 5  # nominal 99.7 %: a single miss in six is already unlikely (2 %)


@pytest.mark.slow
def test_k1_covers_at_the_nominal_rate_from_loads_in_any_direction(data_dir):
    k1 = _k1_coverage(data_dir, 200, 23)
    assert k1["identifiable"].all()
    rate = hits(k1).mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(k1)) + 1.0 / len(k1)
    assert np.all(np.abs(rate - NOMINAL) <= tolerance), (rate, NOMINAL, tolerance)


TEST_ROBOTS = ("arm7", "arm6", "arm6_j3", "track_arm6")
"""The project's own test robots (data/robots/): seven joints, no compensator, a compensator on joint 3, a linear track."""


def _robot_cell(data_dir, name):
    from bayescal.cell.config import load_cell

    return load_cell(data_dir / "robots" / f"{name}.toml")


@pytest.mark.parametrize("name", TEST_ROBOTS)
def test_intervals_of_the_test_robots_are_not_grossly_miscalibrated_on_three_campaigns(data_dir, name):
    cell = _robot_cell(data_dir, name)
    sampler = GibbsSampler(n_chains=2, n_tune=150, n_draws=300)
    table = elastostatic_coverage(cell, 3, 41, sampler=sampler, angles=5, per_angle=3, repeats=2)
    group = table[table["identifiable"] & table["parameter"].str.fullmatch(r"k[0-9]+")]
    # The compensated joint's own compliance (joint 2's without a compensator) is identified on every robot.
    assert f"k{1 + (1 if cell.compensated_joint is None else cell.compensated_joint)}" in set(group["parameter"])
    assert ("K_c" in set(table["parameter"])) == (cell.compensator is not None)
    counted = hits(group)
    n = counted.shape[0]
    low, high = stats.binom.ppf(0.0005, n, NOMINAL), stats.binom.ppf(0.9995, n, NOMINAL)
    assert np.all((low <= counted.sum(axis=0)) & (counted.sum(axis=0) <= high)), (counted.sum(axis=0), low, high)


@pytest.mark.slow
@pytest.mark.parametrize("name", TEST_ROBOTS)
def test_intervals_of_the_test_robots_cover_at_nominal_rates_on_50_campaigns(data_dir, name):
    # Truths drawn around the cell's values (compliances ±30 %, spring, masses), random plans, 8 μm noise.
    table = elastostatic_coverage(_robot_cell(data_dir, name), 50, 31)
    group = table[table["identifiable"] & table["parameter"].str.fullmatch(r"k[0-9]+")]
    rates = hits(group).mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(group)) + 1.0 / len(group)
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL, tolerance)


def test_a_robot_without_a_compensator_is_not_grossly_miscalibrated_on_the_independent_generator(data_dir):
    from bayescal_studies.studies.elastostatic_coverage import independent_coverage

    table = independent_coverage(_robot_cell(data_dir, "arm6"), 3, 43, angles=4, per_angle=3, repeats=2, executor=ThreadPoolExecutor(2))
    assert set(table["parameter"]) >= {"k2", "k3", "k5"}
    counted = hits(table)
    low, high = stats.binom.ppf(0.0005, len(table), NOMINAL), stats.binom.ppf(0.9995, len(table), NOMINAL)
    assert np.all((low <= counted.sum(axis=0)) & (counted.sum(axis=0) <= high)), (counted.sum(axis=0), low, high)


@pytest.mark.slow
def test_a_robot_without_a_compensator_covers_at_nominal_rates_on_the_independent_generator(data_dir):
    # Truths, tool and anisotropic tracker noise of bayescal.twin.independent, written apart from the model.
    from bayescal_studies.studies.elastostatic_coverage import independent_coverage

    table = independent_coverage(_robot_cell(data_dir, "arm6"), 50, 32)
    rates = hits(table).mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(table)) + 1.0 / len(table)
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL, tolerance)
