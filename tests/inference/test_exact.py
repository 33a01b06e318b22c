"""Tests of bayescal.inference.exact: the exact model's deflections, a campaign's solved together against one
configuration at a time, the mass scale and the relinearisation."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.inference.equations import deflection_equations
from bayescal.inference.exact import ExactCorrection, campaign_deflections, exact_deflections, linearisation_offset, scale_masses
from bayescal.robot.stiffness import compliance_design
from bayescal_studies.studies.elastostatic_coverage import random_plan
from bayescal.twin.simulator import DigitalTwin
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


def _one_at_a_time(cell, campaign, equations, compliances, k2):
    expected = np.empty((len(campaign), 3))
    for config in np.unique(campaign.config):
        rows = np.flatnonzero(campaign.config == config)
        q = campaign.q[rows[0]]
        k = np.array(compliances)
        if equations.joint is not None:
            k[equations.joint] = cell.compensator.own_compliance(q[equations.joint], k2[equations.angle[3 * rows[0]]])
        expected[rows] = exact_deflections(
            cell.robot, q, campaign.wrench[rows[0]], k, cell.compensator,
            unloaded_positions=campaign.p0[rows], load_point=cell.load_point, compensated_joint=equations.joint,
        )
    return expected


@pytest.mark.parametrize("name", ["kr270.toml", "robots/arm7.toml", "robots/arm6.toml", "robots/track_arm6.toml"])
def test_campaign_deflections_equal_the_loop_over_configurations(data_dir, name):
    cell = load_cell(data_dir / name)
    rng = np.random.default_rng(11)
    campaign = DigitalTwin(cell).simulate(random_plan(cell, 4, 2, rng), 2, rng)
    joint = cell.compensated_joint if cell.compensator else None
    equations, _, _ = deflection_equations(cell.robot, campaign, joint=joint)
    compliances = np.asarray(cell.compliances) * rng.uniform(0.8, 1.25, cell.robot.nq)
    k2 = np.empty(0)
    if joint is not None:
        k2 = cell.compensator.equivalent_compliance(equations.compensated_angles, compliances[joint]) * rng.uniform(0.9, 1.1, equations.compensated_angles.size)
    expected = _one_at_a_time(cell, campaign, equations, compliances, k2)
    batched = campaign_deflections(cell.robot, campaign, equations, compliances, k2, cell.compensator, cell.load_point)
    # Deflections of millimetres, the difference of positions of metres: equal to a picometre, the positions' rounding.
    assert np.abs(expected).max() > 1e-4
    np.testing.assert_allclose(batched, expected, rtol=0, atol=1e-12)
    offset = linearisation_offset(cell.robot, campaign, equations, compliances, k2, cell.compensator, cell.load_point)
    assert offset.shape == (equations.n,) and np.all(np.isfinite(offset))


def test_the_linearisation_point_moves_to_a_posterior_mean_far_from_it_and_stays_near_it():
    from bayescal.inference.exact import moved_point

    rng = np.random.default_rng(0)
    K_c, s0, g = rng.normal(660e3, 1.5e3, 4000), rng.normal(0.575, 4e-4, 4000), rng.normal(1.0, 0.01, 4000)
    spring = np.column_stack([np.full(4000, 3.3e6), K_c, s0])
    assert moved_point(spring, g, np.array([660e3, 660e3 * 0.575, 1.0])) is None
    point = moved_point(spring, g, np.array([144e3, 144e3 * 0.458, 1.0]))
    assert point == pytest.approx((K_c.mean(), np.mean(K_c * s0) / K_c.mean(), g.mean()))
    # within 3 sd the point stays; the mass scale alone off by 4 sd moves it
    assert moved_point(spring, g, np.array([662e3, 662e3 * 0.575, 1.02])) is None
    assert moved_point(spring, g, np.array([660e3, 660e3 * 0.575, 1.04])) is not None
