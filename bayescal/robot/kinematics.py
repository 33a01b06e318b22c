"""A serial robot read from a URDF file: kinematics, Jacobians and gravity torques.

Everything is computed by Pinocchio; this module only fixes the conventions the
rest of the package relies on:

* joint positions ``q`` are the controller's, one per chain joint: rad for a
  revolute joint (deg in files, column ``q<j>_deg``), m for a prismatic one (mm in
  files, column ``q<j>_mm``); compliances are rad/(N·m) and m/N, μrad/(N·m) and
  μm/N at the edges (the chain and the locked joints: :mod:`bayescal.robot.chain`);
* points on the tool are given in the ``flange`` frame, in m;
* velocities and Jacobians are expressed in the base axes at the point they
  describe (Pinocchio's ``LOCAL_WORLD_ALIGNED``), rows ordered ``[v; ω]``;
* :meth:`Robot.gravity_torque` is Pinocchio's ``g(q)``: the torque the drives
  supply to hold the arm still, the negative of the generalized gravity force.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path

import numpy as np
import pinocchio as pin

from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.chain import joint_kind, reduce_to_chain
from bayescal.units import DEG, MM

__all__ = ["Robot", "Workspace", "scaled_links"]

_LIMIT_TOLERANCE = 1e-9
"""Slack on joint limits (rad; times 1 mm/m, m, for a prismatic joint) so that a plan written at a limit in deg or mm is accepted."""


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
        Joint limits, rad or m.
    prismatic : numpy.ndarray of bool
        (nq,) which joints are prismatic.
    position_scale : numpy.ndarray
        (nq,) SI value of one file unit of each joint's position: :data:`~bayescal.units.DEG` or :data:`~bayescal.units.MM`.
    position_units, compliance_units : tuple of str
        Each joint's units at the edges: ``"deg"`` or ``"mm"``; ``"μrad/(N·m)"`` or ``"μm/N"``.
    position_columns : tuple of str
        The campaign and plan files' column of each joint: ``q<j>_deg`` or ``q<j>_mm``.
    flange : str
        Name of the flange frame.
    tool_mass : float
        The tool's weighed mass, kg, already in the flange body's inertia (:meth:`with_tool`); 0 without a tool.
    tool_centre : numpy.ndarray
        (3,) the tool's centre of mass, flange frame, m.
    """

    def __init__(
        self, model: pin.Model, *, flange: str = "flange", source: str | None = None, tool_mass: float = 0.0, tool_centre=None
    ) -> None:
        kinds = [joint_kind(joint) for joint in list(model.joints)[1:]]
        if None in kinds:
            name = list(model.names)[1 + kinds.index(None)]
            raise InputError(
                f"joint '{name}' is neither revolute nor prismatic (a 'continuous' joint has two coordinates: "
                "give it limits and type 'revolute')",
                source=source,
            )
        if not model.existFrame(flange):
            raise InputError(f"the model has no frame named '{flange}'", source=source)
        self.model = model
        self.nq = int(model.nq)
        self.joint_names = tuple(str(name) for name in list(model.names)[1:])
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        self.prismatic = np.array([kind == "prismatic" for kind in kinds], dtype=bool)
        self.position_scale = np.where(self.prismatic, MM, DEG)
        self.position_units = tuple("mm" if p else "deg" for p in self.prismatic)
        self.compliance_units = tuple("μm/N" if p else "μrad/(N·m)" for p in self.prismatic)
        self.position_columns = tuple(f"q{j + 1}_{unit}" for j, unit in enumerate(self.position_units))
        self.flange = flange
        self.source = source
        self._flange_id = model.getFrameId(flange)
        self._flange_frame = model.frames[self._flange_id]
        self.tool_mass = float(tool_mass)
        self.tool_centre = np.zeros(3) if tool_centre is None else np.asarray(tool_centre, dtype=float).reshape(3)

    def with_model(self, model: pin.Model) -> Robot:
        """A robot of ``model`` (a changed copy of this one's: its placements or masses) with this one's flange, source and tool."""
        return Robot(model, flange=self.flange, source=self.source, tool_mass=self.tool_mass, tool_centre=self.tool_centre)

    def with_tool(self, mass: float, centre) -> Robot:
        """A copy carrying a tool of ``mass`` kg whose centre of mass is ``centre`` (3,) m, flange frame.

        The tool's weight joins the flange body's inertia (as a point mass: its rotational inertia does not
        enter the statics), so that every gravity torque of the model, Pinocchio's and
        :class:`~bayescal.robot.batched.BatchedChain`'s, carries it.  A mass of 0 returns this robot itself.
        """
        if mass == 0.0:
            return self
        model = self.model.copy()
        joint = self._flange_frame.parentJoint
        model.inertias[joint] = model.inertias[joint] + self.tool_inertia(mass, centre)
        return Robot(model, flange=self.flange, source=self.source, tool_mass=mass, tool_centre=centre)

    def tool_inertia(self, mass: float | None = None, centre=None) -> pin.Inertia:
        """A point mass (default: the tool's) at ``centre`` (flange frame, m) in the frame of the flange's parent joint."""
        mass = self.tool_mass if mass is None else mass
        centre = self.tool_centre if centre is None else np.asarray(centre, dtype=float).reshape(3)
        return pin.Inertia(float(mass), self._flange_frame.placement.act(centre), np.zeros((3, 3)))

    @classmethod
    def from_urdf(
        cls,
        path: str | PathLike[str],
        *,
        flange: str = "flange",
        joints: list[str] | None = None,
        locked: dict[str, tuple[float, str]] | None = None,
    ) -> Robot:
        """Load a robot from a URDF file; ``flange`` names the tool frame (a link or fixed joint).

        ``joints`` names the chain's joints base to flange and ``locked`` the values and kinds
        of joints locked away from 0 (:func:`~bayescal.robot.chain.reduce_to_chain`).
        """
        file = Path(path)
        if not file.is_file():
            raise InputError("URDF file not found", source=str(path))
        record_read(file, "the robot's URDF")
        try:
            model = pin.buildModelFromUrdf(str(file))
        except (RuntimeError, ValueError) as exc:
            raise InputError(f"cannot read the URDF: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", source=str(path)) from None
        if not model.existFrame(flange):
            raise InputError(f"the model has no frame named '{flange}'", source=str(path))
        model = reduce_to_chain(model, flange, joints=joints, locked=locked, source=str(path))
        return cls(model, flange=flange, source=str(path))

    def _q(self, q) -> np.ndarray:
        q = np.asarray(q, dtype=float)
        if q.shape != (self.nq,):
            raise ValueError(f"expected {self.nq} joint angles, got shape {q.shape}")
        return q

    def workspace(self) -> Workspace:
        """A new workspace of this robot: the Pinocchio data one task computes in (see :class:`Workspace`)."""
        return Workspace(self, self.model.createData())

    # The calls below each run in a workspace of their own, so that any thread or
    # process may call them on a shared robot; a loop over many configurations
    # holds one workspace instead (creating one costs several kinematic calls).

    def flange_pose(self, q) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (3, 3) and origin (3,) of the flange frame in the base frame, m (:meth:`Workspace.flange_pose`)."""
        return self.workspace().flange_pose(q)

    def point_position(self, q, point_in_flange) -> np.ndarray:
        """Base-frame position (m) of a flange-frame point (:meth:`Workspace.point_position`)."""
        return self.workspace().point_position(q, point_in_flange)

    def joint_origins(self, q) -> np.ndarray:
        """(nq, 3) base-frame positions (m) of the joint frames' origins (:meth:`Workspace.joint_origins`)."""
        return self.workspace().joint_origins(q)

    def point_in_flange(self, q, point_in_base) -> np.ndarray:
        """Flange-frame coordinates (m) of a base-frame point (:meth:`Workspace.point_in_flange`)."""
        return self.workspace().point_in_flange(q, point_in_base)

    def point_jacobian(self, q, point_in_flange) -> np.ndarray:
        """(3, nq) Jacobian of a material point of the flange body, base axes (:meth:`Workspace.point_jacobian`)."""
        return self.workspace().point_jacobian(q, point_in_flange)

    def flange_jacobian(self, q) -> np.ndarray:
        """(6, nq) Jacobian at the flange origin, base axes, rows ``[v; ω]`` (:meth:`Workspace.flange_jacobian`)."""
        return self.workspace().flange_jacobian(q)

    def point_hessian(self, q, point_in_flange) -> np.ndarray:
        """(6, nq, nq) kinematic Hessian at a material point of the flange body (:meth:`Workspace.point_hessian`)."""
        return self.workspace().point_hessian(q, point_in_flange)

    def gravity_torque(self, q) -> np.ndarray:
        """(nq,) joint torques (N·m) that hold the arm against its own weight (:meth:`Workspace.gravity_torque`)."""
        return self.workspace().gravity_torque(q)

    def gravity_torque_derivative(self, q) -> np.ndarray:
        """(nq, nq) ``∂g/∂q`` (:meth:`Workspace.gravity_torque_derivative`)."""
        return self.workspace().gravity_torque_derivative(q)

    def check_limits(self, q, *, source: str | PathLike[str] | None = None, line: int | None = None) -> None:
        """Raise :class:`~bayescal.errors.InputError` naming the first joint outside its limits.

        The column named in the error is the campaign and plan files' (``q<j>_deg`` or ``q<j>_mm``).
        """
        q = self._q(q)
        for j, (value, low, high) in enumerate(zip(q, self.lower, self.upper)):
            slack = _LIMIT_TOLERANCE * (MM if self.prismatic[j] else 1.0)
            if not (low - slack <= value <= high + slack):
                scale, unit = self.position_scale[j], self.position_units[j]
                raise InputError(
                    f"joint {self.joint_names[j]} at {value / scale:.3f} {unit} is outside its limits "
                    f"{low / scale:.1f} to {high / scale:.1f} {unit}",
                    source=source,
                    line=line,
                    column=self.position_columns[j],
                )


def scaled_links(robot: Robot, factor: float) -> pin.Model:
    """A copy of ``robot``'s model with every link's mass and rotational inertia multiplied by ``factor``, the centres
    of mass kept, and the tool's weight (:meth:`Robot.with_tool`) unscaled: a weighed tool is not the URDF's guess."""
    model = robot.model.copy()
    tool_joint = robot._flange_frame.parentJoint
    tool = robot.tool_inertia()
    for i in range(1, model.njoints):
        inertia = model.inertias[i]
        if i == tool_joint and robot.tool_mass > 0:
            # Inertias are linear in their dynamic parameters (m, m·c, I): take the tool out, scale the link, put it back.
            link = inertia.toDynamicParameters() - tool.toDynamicParameters()
            model.inertias[i] = pin.Inertia.FromDynamicParameters(link * factor + tool.toDynamicParameters())
        else:
            model.inertias[i] = pin.Inertia(inertia.mass * factor, inertia.lever, inertia.inertia * factor)
    return model


class Workspace:
    """One task's Pinocchio data for a shared, read-only :class:`Robot`: Pinocchio's ``Model``/``Data`` split.

    Each kinematic call writes its intermediate results into the workspace's
    data, so a workspace belongs to one task at a time (a campaign of a study,
    a configuration's equilibrium, a loop over a plan); the robot itself holds
    no mutable state and is shared by every thread and process.

    Parameters
    ----------
    robot
        The robot.
    data
        A ``pinocchio.Data`` of ``robot.model`` (:meth:`Robot.workspace` makes one).
    """

    __slots__ = ("robot", "data")

    def __init__(self, robot: Robot, data: pin.Data) -> None:
        self.robot = robot
        self.data = data

    def _placement(self, q) -> pin.SE3:
        pin.framesForwardKinematics(self.robot.model, self.data, self.robot._q(q))
        return self.data.oMf[self.robot._flange_id]

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
        pin.forwardKinematics(self.robot.model, self.data, self.robot._q(q))
        return np.array([self.data.oMi[j].translation for j in range(1, self.robot.model.njoints)])

    def point_in_flange(self, q, point_in_base) -> np.ndarray:
        """Flange-frame coordinates (m) of a point given in the base frame: the inverse of :meth:`point_position`."""
        rotation, origin = self.flange_pose(q)
        point = np.asarray(point_in_base, dtype=float)
        return (point - origin) @ rotation

    def _local_placement(self, point_in_flange) -> pin.SE3:
        """Placement, relative to the flange's parent joint, of a frame at the point with the flange's axes."""
        offset = pin.SE3(np.eye(3), np.asarray(point_in_flange, dtype=float).reshape(3))
        return self.robot._flange_frame.placement * offset

    def point_jacobian(self, q, point_in_flange) -> np.ndarray:
        """(3, nq) Jacobian of the linear velocity of a material point of the flange body, base axes."""
        pin.computeJointJacobians(self.robot.model, self.data, self.robot._q(q))
        jacobian = pin.getFrameJacobian(
            self.robot.model,
            self.data,
            self.robot._flange_frame.parentJoint,
            self._local_placement(point_in_flange),
            pin.LOCAL_WORLD_ALIGNED,
        )
        return np.array(jacobian[:3])

    def flange_jacobian(self, q) -> np.ndarray:
        """(6, nq) Jacobian at the flange origin, base axes, rows ``[v; ω]``."""
        return np.array(
            pin.computeFrameJacobian(self.robot.model, self.data, self.robot._q(q), self.robot._flange_id, pin.LOCAL_WORLD_ALIGNED)
        )

    def point_hessian(self, q, point_in_flange) -> np.ndarray:
        """(6, nq, nq) kinematic Hessian of a frame at a material point of the flange body.

        ``H[:, i, j]`` is the derivative with respect to ``q[j]`` of column ``i`` of the
        ``LOCAL_WORLD_ALIGNED`` Jacobian of that point, rows ``[v; ω]``.
        """
        pin.computeJointJacobians(self.robot.model, self.data, self.robot._q(q))
        pin.computeJointKinematicHessians(self.robot.model, self.data)
        hessian = pin.getFrameKinematicHessian(
            self.robot.model,
            self.data,
            self.robot._flange_frame.parentJoint,
            self._local_placement(point_in_flange),
            pin.LOCAL_WORLD_ALIGNED,
        )
        # The binding copies Pinocchio's column-major (6, nv, nv) tensor element by element
        # into a row-major array of the same shape: read its memory back in column-major order.
        flat = np.asarray(hessian).ravel(order="K")
        return np.ascontiguousarray(flat.reshape((6, self.robot.model.nv, self.robot.model.nv), order="F"))

    def gravity_torque(self, q) -> np.ndarray:
        """(nq,) joint torques (N·m) that hold the arm against its own weight: Pinocchio's ``g(q)``."""
        return np.array(pin.computeGeneralizedGravity(self.robot.model, self.data, self.robot._q(q)))

    def gravity_torque_derivative(self, q) -> np.ndarray:
        """(nq, nq) derivative ``∂g/∂q`` of :meth:`gravity_torque` (symmetric: the Hessian of the potential energy)."""
        return np.array(pin.computeGeneralizedGravityDerivatives(self.robot.model, self.data, self.robot._q(q)))
