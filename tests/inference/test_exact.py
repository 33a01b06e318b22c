"""Tests of bayescal.inference.exact: the exact model's deflections, the mass scale and the relinearisation."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.inference.exact import ExactCorrection, exact_deflections, scale_masses
from bayescal.robot.stiffness import compliance_design
from bayescal.units import DEG


def test_the_exact_deflection_tends_to_eq_31s_linear_one_as_the_load_vanishes(planar_arm):
    # The planar arm carries no weight about its axes, so the only nonlinearity is the arm's own geometry:
    # the gap between exact and linear deflection shrinks in proportion to the load.
    q = np.array([0.3, 1.1])
    compliances = np.array([2e-5, 3e-5])
    point = np.zeros((1, 3))
    gaps = []
    for force in (200.0, 20.0):
        wrench = np.array([-force, -force, 0.0, 0.0, 0.0, 0.0])
        exact = exact_deflections(planar_arm, q, wrench, compliances, None, points_in_flange=point)[0]
        linear = compliance_design(planar_arm, q, point[0], wrench) @ compliances
        gaps.append(np.linalg.norm(exact - linear) / np.linalg.norm(linear))
    assert gaps[1] < 1e-3
    assert gaps[0] / gaps[1] == pytest.approx(10.0, rel=0.1)


def test_scaling_the_masses_scales_the_weights_joint_torques(robot):
    q = np.array([0.0, -60.0, 80.0, 0.0, 40.0, 0.0]) * DEG
    heavier = scale_masses(robot, 1.15)
    np.testing.assert_allclose(heavier.gravity_torque(q), 1.15 * robot.gravity_torque(q), rtol=1e-9, atol=1e-9)
    assert heavier.nq == robot.nq and heavier.flange == robot.flange


def test_the_relinearisation_recovers_the_compliances_of_exact_deflections(planar_arm):
    from bayescal.cell.campaign import Campaign
    from bayescal.inference.closedform import closed_form
    from bayescal.inference.equations import deflection_equations
    from bayescal.inference.identifiability import analyse

    rng = np.random.default_rng(4)
    truth = np.array([2e-5, 3e-5])
    n = 12
    q = rng.uniform(-1.2, 1.2, (n, 2))
    wrench = np.column_stack([rng.normal(0.0, 300.0, (n, 2)), np.zeros((n, 4))])
    p0 = np.array([planar_arm.point_position(row, [0.0, 0.0, 0.0]) for row in q])
    p1 = p0 + np.array([exact_deflections(planar_arm, row, w, truth, None, points_in_flange=np.zeros((1, 3)))[0] for row, w in zip(q, wrench)])
    campaign = Campaign(config=np.arange(n), repeat=np.zeros(n, dtype=int), marker=np.array(["M"] * n), q=q, wrench=wrench, p0=p0, p1=p1, lines=np.zeros(n, dtype=int))
    equations, torque, _ = deflection_equations(planar_arm, campaign, joint=None)
    ident = analyse(equations.per_angle_design(), equations.per_angle_columns(), equations.compensated_angles, torque, equations.angle[::3])
    linear = closed_form(equations, ident, None)
    correction = ExactCorrection(planar_arm, truth * 0.5, None, None, None)
    exact, offset, iterations, _ = correction.relinearise(campaign, equations, ident, linear)
    # The linear model misreads the deflections of the exact one; corrected, the closed form returns the truth.
    assert np.max(np.abs(linear.compliances / truth - 1)) > 1e-4
    np.testing.assert_allclose(exact.compliances, truth, rtol=1e-6)
    assert 1 <= iterations < 10 and offset.shape == (equations.n,)
