"""Joints turned to their own z axis: the frame the kinematic calibration's corrections are written in.

The kinematic calibration (:mod:`bayescal.kinematics.tree`) takes revolute joints
about their frame's z axis, as a URDF written from a DH table has them.  An
industrial robot's URDF often turns about x or y, or about -z (the KR-270's A1
and A4 turn about -z and -x).  :func:`joints_about_z` rewrites such a model so
that every joint turns about z, with the same geometry and the same signs of
the joint angles: each joint's frame is turned by :func:`axis_frame` of its axis,
the placements, bodies and frames hanging off it by the inverse.

:func:`axis_frame` is the one convention of where a joint's 6-D placement
correction lives when its axis is not z: the digital twin's kinematic errors
(:mod:`bayescal.twin.kinematic_errors`) are drawn in it, so that the calibration's
parameters are the twin's errors themselves.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from bayescal.robot.kinematics import Robot

__all__ = ["axis_frame", "corrected_robot", "joints_about_z"]

_UNIT_Z = np.array([0.0, 0.0, 1.0])


def axis_frame(axis: np.ndarray) -> np.ndarray:
    """``(3, 3)`` the rotation ``A`` with ``A @ z = axis``: the smallest turn from z onto the unit ``axis`` ``(3,)``.

    A half turn about x for ``axis = -z`` (the smallest turn is not unique there).
    """
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.array(pin.Quaternion.FromTwoVectors(_UNIT_Z, axis).matrix())


def joint_axes(model: pin.Model) -> np.ndarray:
    """``(njoints, 3)`` each revolute joint's axis in its own frame (row 0, the universe, is z)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    axes = np.tile(_UNIT_Z, (model.njoints, 1))
    for j in range(1, model.njoints):
        if model.joints[j].nv == 1:
            axes[j] = np.asarray(data.joints[j].S).reshape(-1)[3:]
    return axes


def joints_about_z(model: pin.Model) -> pin.Model:
    """A copy of ``model`` whose revolute joints all turn about their frame's z axis, the geometry unchanged.

    Joint ``j``'s frame is turned by ``A_j`` (:func:`axis_frame` of its axis): its
    placement becomes ``A_parentᵀ · placement · A_j``, its body's inertia and every
    frame on it are expressed in the turned frame.  A joint that is not a
    one-axis revolute (a prismatic one, say) is left as it is, for
    :class:`~bayescal.kinematics.tree.BatchedTree` to name.
    """
    axes = joint_axes(model)
    turns = [axis_frame(a) if model.joints[j].shortname().startswith("JointModelR") else np.eye(3) for j, a in enumerate(axes)]
    if all(np.allclose(t, np.eye(3)) for t in turns):
        return model
    out = pin.Model()
    out.name = model.name
    out.gravity = model.gravity
    for j in range(1, model.njoints):
        turn, parent_turn = pin.SE3(turns[j], np.zeros(3)), pin.SE3(turns[model.parents[j]], np.zeros(3))
        joint = pin.JointModelRZ() if model.joints[j].shortname().startswith("JointModelR") else model.joints[j]
        placement = parent_turn.inverse() * model.jointPlacements[j] * turn
        index = out.addJoint(model.parents[j], joint, placement, model.names[j],
                             model.effortLimit[model.joints[j].idx_v:model.joints[j].idx_v + 1],
                             model.velocityLimit[model.joints[j].idx_v:model.joints[j].idx_v + 1],
                             model.lowerPositionLimit[model.joints[j].idx_q:model.joints[j].idx_q + 1],
                             model.upperPositionLimit[model.joints[j].idx_q:model.joints[j].idx_q + 1])
        out.appendBodyToJoint(index, turn.inverse().act(model.inertias[j]), pin.SE3.Identity())
    for frame in list(model.frames)[1:]:
        turn = pin.SE3(turns[frame.parentJoint], np.zeros(3))
        moved = pin.Frame(frame.name, frame.parentJoint, frame.parentFrame, turn.inverse() * frame.placement, frame.type,
                          turn.inverse().act(frame.inertia))
        out.addFrame(moved, False)
    return out


def corrected_robot(robot: Robot, deltas: np.ndarray) -> Robot:
    """A copy of ``robot`` with joint ``j``'s placement right-multiplied by ``exp(δ_j)``, ``δ_j = deltas[j - 1]``
    ``(tx, ty, tz, rx, ry, rz)`` (m, rad) written in the frame where that joint's axis is z (:func:`axis_frame`).

    The one way a joint placement correction is applied: by the twin to draw a robot that is not its URDF, and
    by ``calibrate --kinematics`` to put a kinematic calibration's identified placements on the cell's robot.
    """
    if deltas.shape != (robot.nq, 6):
        raise ValueError(f"expected corrections of shape ({robot.nq}, 6), got {deltas.shape}")
    model = robot.model.copy()
    axes = joint_axes(model)
    for j in range(1, model.njoints):
        turn = pin.SE3(axis_frame(axes[j]), np.zeros(3))
        model.jointPlacements[j] = model.jointPlacements[j] * (turn * pin.exp6(pin.Motion(deltas[j - 1])) * turn.inverse())
    return robot.with_model(model)
