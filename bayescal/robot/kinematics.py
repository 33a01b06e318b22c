"""A serial robot read from a URDF file: kinematics, Jacobians and gravity torques.

Everything is computed by Pinocchio; this module only fixes the conventions the
rest of the package relies on:

* joint angles ``q`` are the controller's, in rad, one per joint (every joint
  must be a one-degree-of-freedom revolute joint: angles are read in deg and
  compliances are in rad/(N·m));
* points on the tool are given in the ``flange`` frame, in m;
* velocities and Jacobians are expressed in the base axes at the point they
  describe (Pinocchio's ``LOCAL_WORLD_ALIGNED``), rows ordered ``[v; ω]``;
* :meth:`Robot.gravity_torque` is Pinocchio's ``g(q)``: the torque the drives
  supply to hold the arm still, the negative of the generalized gravity force.
"""

from __future__ import annotations

import math
from os import PathLike
from pathlib import Path

import numpy as np
import pinocchio as pin

from bayescal.errors import InputError

__all__ = ["Robot"]

_LIMIT_TOLERANCE = 1e-9
"""Slack (rad) on joint limits so that a plan written at a limit in deg is accepted."""


class Robot:
    """A fixed-base serial robot with a named tool flange frame.

    Parameters
    ----------
    model
        The Pinocchio model.
    flange
        Name of the frame the tool is attached to.
    source
        Where the model came from, used in error messages.

    Attributes
    ----------
    model : pinocchio.Model
    nq : int
        Number of joints.
    joint_names : tuple of str
    lower, upper : numpy.ndarray
        Joint limits, rad.
    flange : str
        Name of the flange frame.
    """

    def __init__(self, model: pin.Model, *, flange: str = "flange", source: str | None = None) -> None:
        if model.nq != model.nv:
            raise InputError(
                "every joint must be a single revolute joint (found a joint with more coordinates "
                "than velocities, e.g. a 'continuous' joint)",
                source=source,
            )
        prismatic = [name for name, joint in zip(list(model.names)[1:], list(model.joints)[1:]) if joint.shortname().startswith("JointModelP")]
        if prismatic:
            raise InputError(f"joint '{prismatic[0]}' is prismatic; every joint must be revolute", source=source)
        if not model.existFrame(flange):
            raise InputError(f"the model has no frame named '{flange}'", source=source)
        self.model = model
        self.nq = int(model.nq)
        self.joint_names = tuple(str(name) for name in list(model.names)[1:])
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        self.flange = flange
        self.source = source
        self._data = model.createData()
        self._flange_id = model.getFrameId(flange)
        self._flange_frame = model.frames[self._flange_id]

    def copy(self) -> Robot:
        """The same robot with its own Pinocchio data: one per thread, since a data object holds each call's results."""
        return Robot(self.model.copy(), flange=self.flange, source=self.source)

    @classmethod
    def from_urdf(cls, path: str | PathLike[str], *, flange: str = "flange") -> Robot:
        """Load a robot from a URDF file; ``flange`` names the tool frame (a link or fixed joint)."""
        file = Path(path)
        if not file.is_file():
            raise InputError("URDF file not found", source=str(path))
        try:
            model = pin.buildModelFromUrdf(str(file))
        except (RuntimeError, ValueError) as exc:
            raise InputError(f"cannot read the URDF: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", source=str(path)) from None
        return cls(model, flange=flange, source=str(path))

    def _q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.nq,):
            raise ValueError(f"expected {self.nq} joint angles, got shape {q.shape}")
        return q

    def _placement(self, q) -> pin.SE3:
        pin.framesForwardKinematics(self.model, self._data, self._q(q))
        return self._data.oMf[self._flange_id]

    def flange_pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (3, 3) and origin (3,) of the flange frame in the base frame, m."""
        placement = self._placement(q)
        return placement.rotation.copy(), placement.translation.copy()

    def point_position(self, q, point_in_flange) -> np.ndarray:
        """Base-frame position (m) of a point given in the flange frame; (3,) or (k, 3) like the input."""
        rotation, origin = self.flange_pose(q)
        point = np.asarray(point_in_flange, dtype=float)
        return point @ rotation.T + origin

    def joint_origins(self, q) -> np.ndarray:
        """(nq, 3) base-frame positions (m) of the joint frames' origins, in joint order."""
        pin.forwardKinematics(self.model, self._data, self._q(q))
        return np.array([self._data.oMi[j].translation for j in range(1, self.model.njoints)])

    def point_in_flange(self, q, point_in_base) -> np.ndarray:
        """Flange-frame coordinates (m) of a point given in the base frame: the inverse of :meth:`point_position`."""
        rotation, origin = self.flange_pose(q)
        point = np.asarray(point_in_base, dtype=float)
        return (point - origin) @ rotation

    def _local_placement(self, point_in_flange) -> pin.SE3:
        """Placement, relative to the flange's parent joint, of a frame at the point with the flange's axes."""
        offset = pin.SE3(np.eye(3), np.asarray(point_in_flange, dtype=float).reshape(3))
        return self._flange_frame.placement * offset

    def point_jacobian(self, q, point_in_flange) -> np.ndarray:
        """(3, nq) Jacobian of the linear velocity of a material point of the flange body, base axes."""
        pin.computeJointJacobians(self.model, self._data, self._q(q))
        jacobian = pin.getFrameJacobian(
            self.model,
            self._data,
            self._flange_frame.parentJoint,
            self._local_placement(point_in_flange),
            pin.LOCAL_WORLD_ALIGNED,
        )
        return np.array(jacobian[:3])

    def flange_jacobian(self, q) -> np.ndarray:
        """(6, nq) Jacobian at the flange origin, base axes, rows ``[v; ω]``."""
        return np.array(
            pin.computeFrameJacobian(self.model, self._data, self._q(q), self._flange_id, pin.LOCAL_WORLD_ALIGNED)
        )

    def point_hessian(self, q, point_in_flange) -> np.ndarray:
        """(6, nq, nq) kinematic Hessian of a frame at a material point of the flange body.

        ``H[:, i, j]`` is the derivative with respect to ``q[j]`` of column ``i`` of the
        ``LOCAL_WORLD_ALIGNED`` Jacobian of that point, rows ``[v; ω]``.
        """
        pin.computeJointJacobians(self.model, self._data, self._q(q))
        pin.computeJointKinematicHessians(self.model, self._data)
        hessian = pin.getFrameKinematicHessian(
            self.model,
            self._data,
            self._flange_frame.parentJoint,
            self._local_placement(point_in_flange),
            pin.LOCAL_WORLD_ALIGNED,
        )
        # The binding exposes Pinocchio's column-major tensor with its axes reversed.
        return np.ascontiguousarray(np.asarray(hessian).transpose(2, 1, 0))

    def gravity_torque(self, q) -> np.ndarray:
        """(nq,) joint torques (N·m) that hold the arm against its own weight: Pinocchio's ``g(q)``."""
        return np.array(pin.computeGeneralizedGravity(self.model, self._data, self._q(q)))

    def gravity_torque_derivative(self, q) -> np.ndarray:
        """(nq, nq) derivative ``∂g/∂q`` of :meth:`gravity_torque` (symmetric: the Hessian of the potential energy)."""
        return np.array(pin.computeGeneralizedGravityDerivatives(self.model, self._data, self._q(q)))

    def check_limits(self, q, *, source: str | PathLike[str] | None = None, line: int | None = None) -> None:
        """Raise :class:`~bayescal.errors.InputError` naming the first joint outside its limits.

        The column named in the error is ``q<j>_deg``, the campaign and plan files' column.
        """
        q = self._q(q)
        for j, (value, low, high) in enumerate(zip(q, self.lower, self.upper)):
            if not (low - _LIMIT_TOLERANCE <= value <= high + _LIMIT_TOLERANCE):
                raise InputError(
                    f"joint {self.joint_names[j]} at {math.degrees(value):.3f} deg is outside its limits "
                    f"{math.degrees(low):.1f} to {math.degrees(high):.1f} deg",
                    source=source,
                    line=line,
                    column=f"q{j + 1}_deg",
                )
