"""Tests of bayescal.design.criteria and .prediction: eqs 37-40 on the linearised compensated model, and of .linearisation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayescal.design.criteria import (
    CRITERIA,
    configuration_design,
    configuration_information,
    criterion_values,
    prior_mean_square,
    test_pose_design,
    wrench_information,
)
from bayescal.design.linearisation import ExactLinearisation
from bayescal.design.prediction import criterion_value, predict
from bayescal_studies.studies.precision import design_precision


def _information(cell, plan, repeats=3, exact=None):
    return sum(configuration_information(cell, q, m, repeats, exact=exact) for q, m in zip(plan.q, plan.load_kg))


def test_widths_are_those_of_the_eq_37_precision(cell, plan):
    prediction = predict(cell, _information(cell, plan))
    expected = design_precision(cell, plan, repeats=3)["width_3sd_pct"]
    np.testing.assert_allclose(prediction.summary()["width_3sd_pct"], expected, rtol=1e-6)
    assert not prediction.excited[0]  # k1: hanging loads exert no torque about the vertical A1


def test_rho0_is_the_trace_of_eq_39_and_scales_with_repeats(cell, plan):
    information = _information(cell, plan)
    prediction = predict(cell, information)
    excited = prediction.excited
    G0 = test_pose_design(cell)[:, excited]
    direct = math.sqrt(np.trace(G0 @ np.linalg.inv(information[np.ix_(excited, excited)]) @ G0.T))
    assert prediction.rho0_identified == pytest.approx(direct, rel=1e-8)
    # k1, not excited by hanging loads, adds its prior's mean-square relative error times its column of G0.
    k1 = test_pose_design(cell)[:, 0]
    assert prediction.rho0 == pytest.approx(math.sqrt(direct**2 + k1 @ k1 * prior_mean_square(cell.compliance_log_sd)), rel=1e-10)
    assert predict(cell, 4 * information).rho0_identified == pytest.approx(prediction.rho0_identified / 2, rel=1e-10)
    quiet = replace(cell, tracker=replace(cell.tracker, factor=cell.tracker.factor / 10))
    assert predict(quiet, _information(quiet, plan)).rho0_identified == pytest.approx(prediction.rho0_identified / 10, rel=1e-10)


def test_the_prior_mean_square_is_the_log_normal_s_about_its_median():
    z = np.random.default_rng(0).standard_normal(400_000)
    assert prior_mean_square(0.5) == pytest.approx(np.mean((np.exp(0.5 * z) - 1) ** 2), rel=0.01)
    assert prior_mean_square(0.5) == pytest.approx(0.3825, abs=1e-4)


def test_batched_criteria_equal_the_single_ones(cell, plan):
    halves = np.array([_information(cell, plan), _information(cell, plan, repeats=1)])
    for criterion in CRITERIA:
        batch = criterion_values(cell, halves, criterion)
        single = [criterion_value(predict(cell, matrix), criterion) for matrix in halves]
        np.testing.assert_allclose(batch, single, rtol=1e-9)
    with pytest.raises(ValueError, match="unknown criterion"):
        criterion_values(cell, halves, "a-optimal")


def test_two_q2_angles_cannot_separate_the_compensator(cell, plan):
    two = replace(plan, q=plan.q[:6], load_kg=plan.load_kg[:6])  # q2 = -0.01 and -25.24 deg only
    prediction = predict(cell, _information(cell, two))
    assert math.isinf(prediction.rho0) and math.isinf(criterion_value(prediction, "compensator"))
    assert np.all(np.isnan(prediction.relative_sd))
    payload = prediction.to_json()
    assert payload["criterion"] is None and payload["parameters"]["K_c"]["width_3sd_pct"] is None


def test_design_rows_follow_the_markers_and_noise_doubles_two_readings(cell, plan):
    q = plan.q[3]
    design, sigma = configuration_design(cell, q, cell.load_wrench(q, 250.0))
    assert design.shape == (3 * len(cell.markers), 8)
    points = cell.robot.point_position(q, np.array(list(cell.markers.values())))
    np.testing.assert_allclose(sigma[::3], np.sqrt(2) * cell.tracker.sigma(points))


def test_exact_linearisation_agrees_with_eq_31_on_the_joints(cell, plan):
    exact = ExactLinearisation(cell)
    q, mass = plan.q[3], 250.0
    linear, _ = configuration_design(cell, q, cell.load_wrench(q, mass))
    design, _ = exact.configuration_design(q, mass)
    joints = slice(1, 6)
    # gravity's geometric terms change eq 31 by a few per cent at most
    np.testing.assert_allclose(design[:, joints], linear[:, joints], atol=0.05 * np.abs(linear[:, joints]).max())
    # the compensator's static torque moves the arm: K_c and s0 act beyond eq 8's stiffness
    assert np.linalg.norm(design[:, 7] - linear[:, 7]) > np.linalg.norm(linear[:, 7])
    np.testing.assert_allclose(exact.test_design()[:, joints], test_pose_design(cell)[:, joints], atol=0.05 * np.abs(test_pose_design(cell)).max())


def test_a_hanging_plan_and_one_with_sideways_loads_are_scored_on_one_footing(cell, plan):
    from bayescal_studies.studies.load_directions import sideways

    hanging = predict(cell, _information(cell, plan))
    turned_plan = sideways(cell, plan, 3)
    turned = predict(cell, sum(wrench_information(cell, q, w, 3) for q, w in zip(turned_plan.q, turned_plan.wrenches(cell))))
    # Without k1's prior the hanging plan looked as good (its data part alone is a few μm); with it, the
    # plan that identifies k1 is far better, as the simulated campaigns find (docs/design.md).
    assert turned.excited[0] and not hanging.excited[0]
    assert hanging.rho0_identified < 2 * turned.rho0
    assert turned.rho0 < 0.05 * hanging.rho0 and turned.prior_share == 0.0 and hanging.prior_share > 0.99
    payload = hanging.to_json()
    assert "k1" in payload["criterion_includes"] and payload["criterion_identified_only"] < payload["criterion"]


CHOLESKY_AGREEMENT = 4.0
"""The Cholesky factor's criteria and the eigenvalues' differ by rounding that grows with the condition number κ of the
unit-diagonal information: allowed up to this many κ × the double's rounding unit, relative (measured: at most 0.96 on
332 random sub-plans of Table III's, κ from 59 to 1.3 × 10⁹)."""


def test_the_cholesky_scores_are_the_eigenvalues_to_rounding(cell, plan, monkeypatch):
    from bayescal.design import criteria

    parts = np.array([configuration_information(cell, q, m, 3) for q, m in zip(plan.q, plan.load_kg)])
    rng = np.random.default_rng(0)
    information = np.array([parts[rng.choice(len(parts), size=k, replace=False)].sum(axis=0) for k in rng.integers(1, len(parts) + 1, 200)])
    for criterion in CRITERIA:
        fast = criterion_values(cell, information, criterion)
        with monkeypatch.context() as patch:
            patch.setattr(criteria, "DECIDED_MARGIN", math.inf)  # no plan decided by the factor: every one by eigh
            eigen = criterion_values(cell, information, criterion)
        usable = np.isfinite(eigen)
        assert 0 < usable.sum() < len(information)  # the batch holds plans that cannot deliver the criterion too
        np.testing.assert_array_equal(np.isfinite(fast), usable)
        # scored apart from the singular ones, which send their whole batch to eigh, the usable ones are factorised
        fast = criterion_values(cell, information[usable], criterion)
        condition = np.array([_unit_condition(matrix) for matrix in information[usable]])
        assert np.all(np.abs(fast / eigen[usable] - 1.0) <= CHOLESKY_AGREEMENT * condition * np.finfo(float).eps)


def _unit_condition(information: np.ndarray) -> float:
    """Condition number of the excited parameters' information scaled to a unit diagonal, as the criteria score it."""
    diagonal = np.diag(information)
    excited = diagonal > 1e-18 * diagonal.max()
    scale = 1.0 / np.sqrt(diagonal[excited])
    values = np.linalg.eigvalsh(information[np.ix_(excited, excited)] * np.outer(scale, scale))
    return values[-1] / values[0]
