"""Tests of bayescal.design.criteria: eqs 37-40 on the linearised compensated model, and the exact linearisation."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayescal.design.criteria import (
    CRITERIA,
    ExactLinearisation,
    configuration_design,
    configuration_information,
    criterion_value,
    criterion_values,
    predict,
    test_pose_design,
)
from bayescal.studies.precision import design_precision


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
    assert prediction.rho0 == pytest.approx(direct, rel=1e-8)
    assert predict(cell, 4 * information).rho0 == pytest.approx(prediction.rho0 / 2, rel=1e-10)
    quiet = replace(cell, tracker=replace(cell.tracker, factor=cell.tracker.factor / 10))
    assert predict(quiet, _information(quiet, plan)).rho0 == pytest.approx(prediction.rho0 / 10, rel=1e-10)


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
