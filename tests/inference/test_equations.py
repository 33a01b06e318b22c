"""Tests of bayescal.inference.equations: the scalar equations of eq 30, checked by hand on a planar arm."""

from __future__ import annotations

import math

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.inference.equations import MAX_ANGLES, DeflectionEquations, deflection_equations, group_angles
from bayescal.inference.parameters import ANGLE_DECIMALS
from bayescal.units import DEG

from tests.conftest import PLANAR_LINKS

L1, L2 = PLANAR_LINKS


def _campaign(q: np.ndarray, wrench: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> Campaign:
    n = len(q)
    return Campaign(
        config=np.arange(n), repeat=np.zeros(n, dtype=int), marker=np.array(["M"] * n), q=q, wrench=wrench, p0=p0, p1=p1, lines=np.zeros(n, dtype=int)
    )


def test_the_design_is_the_marker_jacobian_times_the_joint_torque_worked_by_hand(planar_arm):
    # q = (0, 90 deg): joint 2 at (1, 0), the flange at (1, 0.5).  The flange's Jacobian columns are
    # z x (1, 0.5) = (-0.5, 1) and z x (0, 0.5) = (-0.5, 0); a force (-F, -F, 0) there exerts the torques
    # tau = J' f = (0.5 F - F, 0.5 F) = (-0.5 F, 0.5 F), and eq 31's columns are J_j tau_j.
    F = 1000.0
    q = np.array([[0.0, 90 * DEG]])
    wrench = np.array([[-F, -F, 0.0, 0.0, 0.0, 0.0]])
    p0 = np.array([[L1, L2, 0.0]])
    k = np.array([2e-6, 3e-6])
    design_by_hand = np.array([[0.25 * F, -0.25 * F], [-0.5 * F, 0.0], [0.0, 0.0]])
    p1 = p0 + design_by_hand @ k
    equations, torque, points = deflection_equations(planar_arm, _campaign(q, wrench, p0, p1), joint=None)
    np.testing.assert_allclose(equations.design, design_by_hand, atol=1e-9)
    np.testing.assert_allclose(torque, [[-0.5 * F, 0.5 * F]], atol=1e-9)
    np.testing.assert_allclose(points, [[0.0, 0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(equations.y, design_by_hand @ k, atol=1e-15)
    assert equations.group.tolist() == [0, 1, 2] and equations.group_names == ("x", "y", "z")


def test_a_marker_off_the_flange_is_located_from_its_unloaded_position(planar_arm):
    # At q = (0, 0) the flange is at (1.5, 0); a marker 0.2 m further along the link is at (1.7, 0) and moves
    # under a force -F y at the flange by J_marker[:, j] tau_j, tau = (-1.5 F, -0.5 F), J_marker = ((0, 1.7), (0, 0.7)).
    F = 500.0
    q = np.zeros((1, 2))
    wrench = np.array([[0.0, -F, 0.0, 0.0, 0.0, 0.0]])
    p0 = np.array([[L1 + L2 + 0.2, 0.0, 0.0]])
    equations, torque, points = deflection_equations(planar_arm, _campaign(q, wrench, p0, p0), joint=None)
    np.testing.assert_allclose(points, [[0.2, 0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(torque, [[-1.5 * F, -0.5 * F]], atol=1e-9)
    np.testing.assert_allclose(equations.design[1], [1.7 * -1.5 * F, 0.7 * -0.5 * F], atol=1e-9)


def test_the_per_angle_design_splits_the_compensated_joint_by_angle(planar_arm):
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(-1, 1, 6), np.repeat([10, 30, 50], 2) * DEG])
    wrench = np.column_stack([rng.normal(0, 500, (6, 3)), np.zeros((6, 3))])
    p0 = np.array([planar_arm.point_position(row, [0.0, 0.0, 0.0]) for row in q])
    equations, _, _ = deflection_equations(planar_arm, _campaign(q, wrench, p0, p0), joint=1)
    np.testing.assert_allclose(equations.compensated_angles, [10 * DEG, 30 * DEG, 50 * DEG])
    assert equations.per_angle_columns() == [(0, None), (1, 0), (1, 1), (1, 2)]
    split = equations.per_angle_design()
    np.testing.assert_allclose(split[:, 0], equations.design[:, 0])
    # Each equation falls in exactly one angle's column, and the columns add up to joint 2's.
    np.testing.assert_allclose(split[:, 1:].sum(axis=1), equations.design[:, 1])
    assert np.all(np.count_nonzero(split[:, 1:], axis=1) <= 1)


def test_whitening_divides_every_equation_by_its_relative_noise():
    equations = DeflectionEquations(
        y=np.array([2.0, 4.0, 6.0]),
        design=np.array([[2.0], [4.0], [6.0]]),
        angle=np.zeros(3, dtype=int),
        compensated_angles=np.zeros(0),
        group=np.zeros(3, dtype=int),
        group_names=("all",),
        scale=np.array([2.0, 4.0, 6.0]),
        joint=None,
    )
    white = equations.whitened()
    np.testing.assert_allclose(white.y, 1.0)
    np.testing.assert_allclose(white.design, 1.0)
    assert white.scale is None and white.whitened() is white


def test_a_few_angles_are_kept_apart_and_many_are_binned_at_their_mean():
    angles, index = group_angles(np.array([10.0, 20.0, 10.0004, 20.0]) * DEG)
    np.testing.assert_allclose(angles / DEG, [10.0, 20.0])
    assert index.tolist() == [0, 1, 0, 1]
    q2 = np.linspace(-40, 40, 200) * DEG
    centres, index = group_angles(q2)
    assert centres.size == MAX_ANGLES and np.all(np.diff(centres) > 0)
    # The mean of the bin's angles as rounded to ANGLE_DECIMALS of a degree.
    rounding = 0.5 * 10.0**-ANGLE_DECIMALS * DEG
    for bin_ in range(MAX_ANGLES):
        assert math.isclose(centres[bin_], q2[index == bin_].mean(), abs_tol=rounding)
