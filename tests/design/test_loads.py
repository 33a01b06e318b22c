"""Tests of bayescal.design.loads and of plans designed over load directions (eqs 40-41)."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.design.criteria import wrench_information
from bayescal.design.linearisation import ExactLinearisation
from bayescal.design.loads import basis_designs, combined_information, draw_loads, load_sizes, turn_draws, turned
from bayescal.design.optimise import PlanDesigner

SMALL = {"starts": 1, "refine_steps": 60, "candidates_per_angle": 4}


@pytest.fixture(scope="module")
def any_cell(data_dir):
    return load_cell(data_dir / "kr270_any_load.toml")


@pytest.fixture(scope="module")
def free_design(any_cell):
    return PlanDesigner(any_cell, model="linear").optimise(5, 2, "test-pose", rng=1, **SMALL)


def test_the_basis_gives_the_exact_information_within_a_few_percent(any_cell):
    exact = ExactLinearisation(any_cell)
    rng = np.random.default_rng(4)
    q = np.radians([-30.0, -80.0, 60.0, -20.0, 45.0, 70.0])
    basis, sigma = basis_designs(any_cell, q, 2750.0, 500.0, exact)
    loads = draw_loads(4, 2750.0, 500.0, rng)
    for load, combined in zip(loads, combined_information(basis, sigma, loads, 2750.0, 500.0, 3)):
        direct = wrench_information(any_cell, q, any_cell.wrench(q, load[:3], load[3:]), 3, exact=exact)
        # the exact deflections are linear in the load to first order (measured: 0.5-1.3 % on the KR-270)
        assert np.linalg.norm(combined - direct) < 0.03 * np.linalg.norm(direct)
    # eq 31 is exactly linear in the load
    linear, linear_sigma = basis_designs(any_cell, q, 2750.0, 500.0, None)
    direct = wrench_information(any_cell, q, any_cell.wrench(q, loads[1, :3], loads[1, 3:]), 3)
    np.testing.assert_allclose(combined_information(linear, linear_sigma, loads[1:2], 2750.0, 500.0, 3)[0], direct, rtol=1e-9)


def test_load_sizes_and_turns_keep_the_limits(cell, any_cell):
    assert load_sizes(cell, 280.0) == (pytest.approx(280.0 * cell.gravity), 0.0)
    assert load_sizes(any_cell, 280.0) == (2750.0, 500.0)
    rng = np.random.default_rng(0)
    loads = draw_loads(50, 2750.0, 500.0, rng)
    np.testing.assert_allclose(loads[0, :3], [0.0, 0.0, -2750.0])
    np.testing.assert_allclose(np.linalg.norm(loads[:, :3], axis=1), 2750.0)
    np.testing.assert_allclose(np.linalg.norm(loads[:, 3:], axis=1), 500.0)
    assert np.abs(loads[:, :3].mean(axis=0)).max() < 0.4 * 2750.0  # spread over the sphere
    moved = turned(loads[3], 0.05, turn_draws((2750.0, 500.0), rng))
    np.testing.assert_allclose(np.linalg.norm(moved[:3]), 2750.0)
    assert 0 < np.linalg.norm(moved[:3] - loads[3, :3]) < 0.5 * 2750.0
    np.testing.assert_allclose(np.linalg.norm(moved[3:]), 500.0)
    assert np.array_equal(turned(loads[3] * [1, 1, 1, 0, 0, 0], 0.05, turn_draws((2750.0, 0.0), rng))[3:], np.zeros(3))


def test_a_free_direction_plan_is_feasible_and_excites_k1(free_design, any_cell):
    plan = free_design.plan
    assert plan.load_kg is None and plan.force.shape == (10, 3) and plan.couple.shape == (10, 3)
    assert np.linalg.norm(plan.force, axis=1).max() <= 2750.0 + 1e-6
    assert np.linalg.norm(plan.couple, axis=1).max() <= 500.0 + 1e-6
    horizontal = np.hypot(plan.force[:, 0], plan.force[:, 1])
    assert horizontal.max() > 0.2 * 2750.0  # the design uses directions a hanging mass cannot
    assert PlanDesigner(any_cell, model="linear").violations(plan) == []
    table = free_design.summary()
    assert np.isfinite(table.loc["k1", "width_3sd_pct"])
    payload = free_design.to_json()
    assert payload["force_max_N"] <= 2750.0 + 1e-6 and payload["parameters"]["k1"]["excited"]


def test_violations_name_a_load_beyond_the_end_effector(any_cell, free_design, cell):
    from dataclasses import replace

    plan = free_design.plan
    heavy = replace(plan, force=plan.force * 1.1)
    reasons = PlanDesigner(any_cell, model="linear").violations(heavy)
    assert len(reasons) == 10 and "force_max_N" in reasons[0]["reason"]
    # on a cell that can only hang masses, the sideways forces are what breaks the constraints
    sideways = PlanDesigner(cell, model="linear").violations(replace(plan, couple=None))
    assert sideways and all("not straight down" in v["reason"] for v in sideways)
