"""Joints turned to their own z axis: the same robot, the calibration's frames."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from bayescal.kinematics.axes import axis_frame, joints_about_z
from bayescal.kinematics.tree import BatchedTree


@pytest.fixture(scope="module")
def kr270(data_dir):
    return pin.buildModelFromUrdf(str(data_dir / "robots" / "kr270.urdf"))


def test_axis_frame_turns_z_onto_the_axis():
    for axis in ([0, 0, 1], [0, 0, -1], [0, 1, 0], [-1, 0, 0], [1, 2, -2]):
        turn = axis_frame(np.array(axis, dtype=float))
        assert np.allclose(turn @ [0, 0, 1], np.array(axis) / np.linalg.norm(axis), atol=1e-12)
        assert np.allclose(turn.T @ turn, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(turn), 1.0)


def test_the_turned_kr270_has_the_same_frames_gravity_torques_and_angle_signs(kr270):
    turned = joints_about_z(kr270)
    assert [turned.joints[j].shortname() for j in range(1, turned.njoints)] == ["JointModelRZ"] * 6
    data, turned_data = kr270.createData(), turned.createData()
    for q in np.random.default_rng(0).uniform(-1.5, 1.5, (5, kr270.nq)):
        for model, d in ((kr270, data), (turned, turned_data)):
            pin.forwardKinematics(model, d, q)
            pin.updateFramePlacements(model, d)
        for frame in range(kr270.nframes):
            # Every frame where it was: same origin, same axes (the turn is undone on the frames hanging off a joint).
            assert np.allclose(data.oMf[frame].homogeneous, turned_data.oMf[frame].homogeneous, atol=1e-12)
        assert np.allclose(pin.computeGeneralizedGravity(kr270, data, q), pin.computeGeneralizedGravity(turned, turned_data, q), atol=1e-9)
    BatchedTree(turned)  # every joint about z: the calibration's tree takes it


def test_a_model_already_about_z_is_returned_as_it_is(data_dir):
    model = pin.buildModelFromUrdf(str(data_dir / "robots" / "justin.urdf"))
    assert joints_about_z(model) is model
