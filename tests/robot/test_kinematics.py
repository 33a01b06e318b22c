"""Tests of bayescal.robot.kinematics: the KR-270 URDF through Pinocchio."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot


def test_flange_at_zero_matches_the_series_geometry(robot):
    assert robot.nq == 6
    assert robot.joint_names == ("A1", "A2", "A3", "A4", "A5", "A6")
    np.testing.assert_allclose(robot.point_position(np.zeros(6), [0, 0, 0]), [2.930, 0.0, 0.695], atol=1e-12)


def test_joint_limits_are_the_datasheet_values(robot):
    np.testing.assert_allclose(np.degrees(robot.lower), [-185, -146, -119, -350, -125, -350], atol=1e-9)
    np.testing.assert_allclose(np.degrees(robot.upper), [185, 0, 155, 350, 125, 350], atol=1e-9)


def test_total_mass_is_the_documented_estimate(robot):
    assert sum(inertia.mass for inertia in robot.model.inertias) == pytest.approx(1250.0)


def test_increasing_a2_lowers_the_arm_and_a1_turns_clockwise(robot):
    flange = robot.point_position(np.radians([0, 10, 0, 0, 0, 0]), [0, 0, 0])
    assert flange[2] < 0.695
    flange = robot.point_position(np.radians([10, 0, 0, 0, 0, 0]), [0, 0, 0])
    assert flange[1] < 0  # A1 axis points down: positive A1 is clockwise seen from above


def test_point_round_trip_and_batch(robot):
    rng = np.random.default_rng(3)
    q = rng.uniform(robot.lower, robot.upper) * 0.5
    points = rng.normal(size=(4, 3)) * 0.2
    base = robot.point_position(q, points)
    assert base.shape == (4, 3)
    np.testing.assert_allclose(robot.point_in_flange(q, base), points, atol=1e-12)
    np.testing.assert_allclose(base[1], robot.point_position(q, points[1]), atol=1e-15)


def test_point_jacobian_is_the_derivative_of_the_position(robot):
    rng = np.random.default_rng(4)
    q = rng.uniform(robot.lower, robot.upper) * 0.5
    point = np.array([0.25, -0.05, 0.2])
    h = 1e-6
    numeric = np.column_stack(
        [(robot.point_position(q + h * e, point) - robot.point_position(q - h * e, point)) / (2 * h) for e in np.eye(6)]
    )
    np.testing.assert_allclose(robot.point_jacobian(q, point), numeric, atol=1e-8)
    np.testing.assert_allclose(robot.point_jacobian(q, np.zeros(3)), robot.flange_jacobian(q)[:3], atol=1e-14)


def test_flange_jacobian_angular_rows_are_the_joint_axes(robot):
    q = np.radians([30, -40, 50, 20, -30, 10])
    jacobian = robot.flange_jacobian(q)
    # the A1 axis points down in the base frame whatever the pose
    np.testing.assert_allclose(jacobian[3:, 0], [0, 0, -1], atol=1e-14)


def test_point_hessian_is_the_derivative_of_the_jacobian(robot):
    q = np.radians([20, -60, 40, 30, -50, 70])
    point = np.array([0.25, 0.0, 0.2])

    def full(q):
        return np.vstack([robot.point_jacobian(q, point), robot.flange_jacobian(q)[3:]])

    h = 1e-6
    numeric = np.stack([(full(q + h * e) - full(q - h * e)) / (2 * h) for e in np.eye(6)], axis=2)
    np.testing.assert_allclose(robot.point_hessian(q, point), numeric, atol=1e-8)


def test_point_hessian_of_a_seven_joint_arm_is_the_derivative_of_its_jacobian(data_dir):
    # With seven joints the tensor's axes are no longer all of one length (6, 7, 7).
    robot = Robot.from_urdf(data_dir / "robots" / "arm7.urdf")
    q = np.radians([10, -50, 30, 70, -20, 40, 60])
    point = np.array([0.25, 0.0, 0.2])

    def full(q):
        return np.vstack([robot.point_jacobian(q, point), robot.flange_jacobian(q)[3:]])

    h = 1e-6
    numeric = np.stack([(full(q + h * e) - full(q - h * e)) / (2 * h) for e in np.eye(7)], axis=2)
    np.testing.assert_allclose(robot.point_hessian(q, point), numeric, atol=1e-8)


def test_gravity_torque_holds_the_horizontal_arm_up(robot):
    torque = robot.gravity_torque(np.zeros(6))
    # the arm's weight pulls toward +A2 (down), so the drive holds it with a negative torque
    assert torque[1] < -3000
    assert torque[0] == pytest.approx(0.0, abs=1e-9)
    h = 1e-6
    q = np.radians([0, -30, 45, 10, 20, 0])
    numeric = np.column_stack([(robot.gravity_torque(q + h * e) - robot.gravity_torque(q - h * e)) / (2 * h) for e in np.eye(6)])
    np.testing.assert_allclose(robot.gravity_torque_derivative(q), numeric, atol=1e-4)


def test_check_limits_names_the_joint(robot):
    robot.check_limits(np.radians([0, -146, 155, 0, 0, 0]))
    with pytest.raises(InputError) as caught:
        robot.check_limits(np.radians([0, 5.0, 0, 0, 0, 0]), source="plan.csv", line=7)
    message = str(caught.value)
    assert "plan.csv:7" in message and "q2_deg" in message and "A2" in message and "5.000 deg" in message
    assert "\n" not in message


def test_bad_urdf_and_missing_flange(tmp_path, data_dir):
    with pytest.raises(InputError, match="not found"):
        Robot.from_urdf(tmp_path / "none.urdf")
    with pytest.raises(InputError, match="no frame named 'tool0'"):
        Robot.from_urdf(data_dir / "robots" / "kr270.urdf", flange="tool0")
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'>")
    with pytest.raises(InputError, match="cannot read the URDF"):
        Robot.from_urdf(broken)


def test_another_urdf_works_the_same_way(tmp_path):
    urdf = tmp_path / "two.urdf"
    urdf.write_text(
        """<robot name="two">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 1"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="l1"><inertial><origin xyz="0.5 0 0"/><mass value="10"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <link name="l2"><inertial><origin xyz="0.5 0 0"/><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="tip" type="fixed"><parent link="l2"/><child link="flange"/><origin xyz="1 0 0"/></joint>
  <link name="flange"/>
</robot>"""
    )
    robot = Robot.from_urdf(urdf)
    assert robot.nq == 2 and robot.joint_names == ("j1", "j2")
    np.testing.assert_allclose(robot.point_position([0, 0], [0, 0, 0]), [2, 0, 1], atol=1e-12)
    # weights 10 kg at 0.5 m and 5 kg at 1.5 m from j1
    assert robot.gravity_torque([0, 0])[0] == pytest.approx(-9.81 * (10 * 0.5 + 5 * 1.5), rel=1e-3)
    with pytest.raises(InputError, match="j2"):
        robot.check_limits([0, math.radians(150)])


def test_a_prismatic_joint_is_read_in_mm_and_its_jacobian_is_the_slide(data_dir):
    robot = Robot.from_urdf(data_dir / "robots" / "track_arm6.urdf")
    assert robot.nq == 7 and list(robot.prismatic) == [True] + [False] * 6
    assert robot.position_columns[:2] == ("q1_mm", "q2_deg") and robot.compliance_units[0] == "μm/N"
    q = np.array([1.5, 0.3, -0.6, 0.4, 0.2, -0.5, 0.7])
    step = 1e-6
    moved = robot.point_position(q + step * np.eye(7)[0], [0.1, 0.0, 0.0])
    numeric = (moved - robot.point_position(q, [0.1, 0.0, 0.0])) / step
    np.testing.assert_allclose(robot.point_jacobian(q, [0.1, 0.0, 0.0])[:, 0], numeric, atol=1e-6)
    np.testing.assert_allclose(numeric, [1.0, 0.0, 0.0], atol=1e-6)
    with pytest.raises(InputError, match="q1_mm.*|4500.000 mm"):
        robot.check_limits(np.r_[4.5, q[1:]])


def test_joints_off_the_chain_are_named_and_locked_once_the_chain_is_named(data_dir):
    urdf = data_dir / "robots" / "arm6_gripper.urdf"
    with pytest.raises(InputError, match=r'finger_left. is not on the path .* joints = \["J1", "J2", "J3", "J4", "J5", "J6"\]'):
        Robot.from_urdf(urdf)
    chain = [f"J{j}" for j in range(1, 7)]
    held = Robot.from_urdf(urdf, joints=chain)
    bare = Robot.from_urdf(data_dir / "robots" / "arm6.urdf")
    q = np.radians([10.0, -40.0, 60.0, 20.0, -30.0, 45.0])
    assert held.joint_names == tuple(chain)
    np.testing.assert_allclose(held.flange_pose(q)[1], bare.flange_pose(q)[1], atol=1e-12)
    # The fingers' 1 kg now hangs on the arm as part of its last body.
    assert abs(held.gravity_torque(q)[1]) > abs(bare.gravity_torque(q)[1])
    with pytest.raises(InputError, match="'J9'"):
        Robot.from_urdf(urdf, joints=["J1", "J9"])
    with pytest.raises(InputError, match="not a revolute joint"):
        Robot.from_urdf(urdf, joints=chain, locked={"finger_left": (0.1, "revolute")})
    with pytest.raises(InputError, match="once each, from the base"):
        Robot.from_urdf(urdf, joints=["J2", "J1", "J3", "J4", "J5", "J6"])


def test_joint_origins_end_at_the_flange_joint(robot):
    q = np.radians([30.0, -60.0, 40.0, 10.0, -20.0, 50.0])
    origins = robot.joint_origins(q)
    _, flange = robot.flange_pose(q)
    assert origins.shape == (robot.nq, 3)
    # The flange frame sits at the A6 origin (data/robots/kr270.urdf).
    np.testing.assert_allclose(origins[-1], flange, atol=1e-12)
    np.testing.assert_allclose(origins[0], [0.0, 0.0, 0.75], atol=1e-12)


def test_threads_share_one_robot_each_with_its_own_workspace(robot):
    """The robot holds no mutable state: threads calling it at once get what one thread gets alone."""
    from concurrent.futures import ThreadPoolExecutor

    rng = np.random.default_rng(3)
    poses = rng.uniform(robot.lower, robot.upper, size=(64, robot.nq)) * 0.5
    point = np.array([0.1, -0.05, 0.3])

    def kinematics(q):
        workspace = robot.workspace()
        return np.concatenate([workspace.point_jacobian(q, point).ravel(), robot.gravity_torque(q), robot.point_position(q, point)])

    alone = np.array([kinematics(q) for q in poses])
    with ThreadPoolExecutor(8) as pool:
        shared = np.array(list(pool.map(kinematics, poses)))
    np.testing.assert_array_equal(shared, alone)
    assert not hasattr(robot, "_data") and not hasattr(robot, "copy")


def test_a_tools_weight_is_in_every_gravity_torque_and_a_mass_scale_leaves_it(cell):
    from bayescal.inference.exact import scale_masses
    from bayescal.robot.batched import BatchedChain

    q = np.radians([[10.0, -60.0, 70.0, 30.0, -40.0, 20.0], [-30.0, -110.0, 20.0, -90.0, 60.0, 150.0]])
    robot = cell.robot
    assert robot.with_tool(0.0, [0.1, 0.0, 0.0]) is robot and robot.tool_mass == 0.0
    tool = robot.with_tool(38.0, [0.17, 0.0, 0.09])
    weight = -38.0 * np.array(robot.model.gravity.linear)
    chain = BatchedChain.of(tool)
    batched = chain.gravity_torque(chain.poses(q))[0]
    scaled = scale_masses(tool, 1.5)
    for i, pose in enumerate(q):
        expected = robot.gravity_torque(pose) + robot.point_jacobian(pose, [0.17, 0.0, 0.09]).T @ weight
        assert tool.gravity_torque(pose) == pytest.approx(expected, abs=1e-8)
        assert batched[i] == pytest.approx(expected, abs=1e-8)
        # the URDF's links are scaled, the weighed tool is not
        assert scaled.gravity_torque(pose) == pytest.approx(1.5 * robot.gravity_torque(pose) + (expected - robot.gravity_torque(pose)), abs=1e-8)
    assert scaled.tool_mass == 38.0
