"""Tests of bayescal.robot.stiffness: eqs 1, 3, 8 and 31 on the KR-270."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from bayescal.robot.compensator import Compensator
from bayescal.robot import stiffness as st

# Klimchik et al., Table IV (k2..k6) and a k1 estimate, rad/(N·m)
K = np.array([0.30, 0.302, 0.406, 3.002, 3.303, 2.365]) * 1e-6
# Table II geometry, phi from the Table I fit, K_c = 144 N/mm and s0 = 458 mm (Table IV)
COMPENSATOR = Compensator(0.18472, 0.68593, 0.12030, math.radians(99.8), 144e3, 0.458)
Q = np.radians([63.0, -25.24, -12.22, -56.49, 41.42, 150.55])  # Table III, row 2 with group 2's q2


def _flange_displacement(robot, q, theta_a, theta_b):
    rot_a, org_a = robot.flange_pose(q + theta_a)
    rot_b, org_b = robot.flange_pose(q + theta_b)
    return np.concatenate([org_b - org_a, pin.log3(rot_b @ rot_a.T)])


def test_joint_stiffness_adds_the_compensator_on_joint_2():
    q = np.radians([0, -56.9, 30, 0, 0, 0])
    plain = st.joint_stiffness(q, K)
    np.testing.assert_allclose(np.diag(plain), 1 / K)
    with_compensator = st.joint_stiffness(q, K, COMPENSATOR, joint=1)
    difference = with_compensator - plain
    expected = COMPENSATOR.K_c * COMPENSATOR.a * COMPENSATOR.L * COMPENSATOR.eta(q[1])
    assert difference[1, 1] == pytest.approx(expected, rel=1e-12)
    difference[1, 1] = 0
    assert not difference.any()
    with pytest.raises(ValueError):
        st.joint_stiffness(q, np.r_[K[:5], 0.0])


def test_compliance_design_is_eq_31(robot):
    point = np.array([0.2, 0.1, 0.0])
    wrench = np.array([100.0, -50.0, -2500.0, 30.0, 0.0, -20.0])
    design = st.compliance_design(robot, Q, point, wrench)
    jp, jf = robot.point_jacobian(Q, point), robot.flange_jacobian(Q)
    for j in range(6):
        np.testing.assert_allclose(design[:, j], jp[:, j] * (jf[:, j] @ wrench), rtol=1e-12, atol=1e-12)
    # Δp = J_p K⁻¹ J_Fᵀ w: the linear model of the whole arm
    np.testing.assert_allclose(design @ K, jp @ (K * (jf.T @ wrench)), rtol=1e-12)


def test_small_loads_follow_the_linear_model(robot):
    point = np.array([0.2, -0.05, 0.0866])
    wrench = np.array([3.0, -2.0, -10.0, 0.5, 0.2, -0.3])
    theta = st.ElasticArm.linear(robot, K, gravity=False).equilibrium(Q, wrench)
    nonlinear = robot.point_position(Q + theta, point) - robot.point_position(Q, point)
    linear = st.compliance_design(robot, Q, point, wrench) @ K
    np.testing.assert_allclose(nonlinear, linear, rtol=1e-4, atol=1e-12)
    # and the full load differs from the linear model at second order only
    big = 250.0 * wrench
    theta = st.ElasticArm.linear(robot, K, gravity=False).equilibrium(Q, big)
    nonlinear = robot.point_position(Q + theta, point) - robot.point_position(Q, point)
    linear = st.compliance_design(robot, Q, point, big) @ K
    assert np.linalg.norm(nonlinear - linear) < 0.02 * np.linalg.norm(linear)
    assert np.linalg.norm(nonlinear - linear) > 1e-4 * np.linalg.norm(linear)


def test_equilibrium_satisfies_eq_1(robot):
    wrench = np.array([200.0, -300.0, -2600.0, 50.0, -80.0, 120.0])
    theta = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench)
    linked = Q + theta
    torque = robot.flange_jacobian(linked).T @ wrench - robot.gravity_torque(linked)
    torque[1] -= COMPENSATOR.torque(linked[1])
    np.testing.assert_allclose(theta, K * torque, rtol=1e-10, atol=1e-16)
    assert 1e-4 < np.max(np.abs(theta)) < 1e-2


def test_newton_converges_in_a_few_iterations(robot):
    wrench = np.array([0.0, 0.0, -2700.0, 0.0, 0.0, 0.0])
    with pytest.raises(st.EquilibriumError):
        st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench, max_iter=1)
    theta = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench, max_iter=4, tol=1e-12)
    settled = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench, max_iter=50, tol=1e-15)
    np.testing.assert_allclose(theta, settled, rtol=0, atol=1e-12)


def test_cartesian_stiffness_matches_finite_differences(robot):
    wrench = np.array([200.0, -300.0, -2600.0, 50.0, -80.0, 120.0])
    stiffness = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).cartesian_stiffness(Q, wrench)
    base = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench)
    steps = np.array([10.0, 10.0, 10.0, 3.0, 3.0, 3.0])
    numeric = np.zeros((6, 6))
    for i, h in enumerate(steps):
        e = np.zeros(6)
        e[i] = h
        plus = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench + e)
        minus = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, compensated_joint=1).equilibrium(Q, wrench - e)
        numeric[:, i] = _flange_displacement(robot, Q, minus, plus) / (2 * h)
    compliance = np.linalg.inv(stiffness)
    np.testing.assert_allclose(compliance, numeric, rtol=1e-6, atol=1e-9 * np.abs(compliance).max())
    # The Hessian terms matter: the unloaded-linear compliance differs at the 1e-3 level.
    jacobian = robot.flange_jacobian(Q + base)
    naive = jacobian @ np.linalg.solve(st.joint_stiffness(Q + base, K, COMPENSATOR, joint=1), jacobian.T)
    assert np.abs(naive - numeric).max() > 1e-4 * np.abs(numeric).max()


def test_conservative_loads_give_a_symmetric_compliance(robot):
    # A force at a material point of the tool (a hanging mass) plus gravity is conservative.
    wrench = np.zeros(6)
    wrench[2] = -2700.0
    load_point = np.array([0.25, 0.0, 0.2])
    rotation, _ = robot.flange_pose(Q)
    wrench[3:] = np.cross(rotation @ load_point, wrench[:3])
    theta, joint = st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, load_point=load_point, compensated_joint=1).equilibrium_stiffness(Q, wrench)
    np.testing.assert_allclose(joint, joint.T, rtol=0, atol=1e-9 * np.abs(joint).max())
    compliance = np.linalg.inv(st.ElasticArm.linear(robot, K, compensator=COMPENSATOR, load_point=load_point, compensated_joint=1).cartesian_stiffness(Q, wrench))
    np.testing.assert_allclose(compliance, compliance.T, atol=1e-9 * np.abs(compliance).max())
    # with the load at the load point, the loaded equilibrium is eq 1 for that point
    linked = Q + theta
    jacobian = np.vstack([robot.point_jacobian(linked, load_point), robot.flange_jacobian(linked)[3:]])
    torque = jacobian[:3].T @ wrench[:3] - robot.gravity_torque(linked)
    torque[1] -= COMPENSATOR.torque(linked[1])
    np.testing.assert_allclose(theta, K * torque, rtol=1e-10, atol=1e-16)


def test_compensator_balances_the_arm_weight(robot):
    # arm horizontal, forearm horizontal: the compensator holds the arm up, within a factor of 2
    gravity = robot.gravity_torque(np.zeros(6))[1]
    generalized = -COMPENSATOR.torque(0.0)
    assert np.sign(generalized) == np.sign(gravity)
    assert 0.5 < generalized / gravity < 2.0
    # arm vertical: the compensator spring passes through its dead centre
    assert abs(COMPENSATOR.torque(math.radians(-90.0))) < 0.01 * abs(gravity)
    # arm leaning back past the vertical: both change sign
    q = np.radians([0.0, -140.0, 140.0, 0.0, 0.0, 0.0])
    assert np.sign(-COMPENSATOR.torque(q[1])) == np.sign(robot.gravity_torque(q)[1]) == 1


def test_compensator_stiffness_is_small_against_joint_2():
    # With K_c = 144 N/mm the compensator adds well under 1 % to K_θ2^0 (documented limitation).
    q2 = np.radians([-0.01, -25.24, -56.9, -99.85, -140.0])
    ratio = COMPENSATOR.stiffness(q2) * K[1]
    assert np.all(ratio > 0) and np.all(ratio < 0.01)
