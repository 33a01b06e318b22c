"""Virtual-joint (VJM) elastostatics of a serial robot with a gravity compensator on one joint (joint 2 on the KR-270).

Klimchik et al., sections II-III.  Each joint is a rigid actuator held at the
controller's angle ``q`` followed by a virtual spring of compliance ``k_j``
(rad/(N·m)); the links sit at ``q + θ``.  Joint 2 additionally carries the
spring compensator, a link-side generalized force ``-M_c(q2 + θ2)`` whose
derivative adds ``K_c a L η`` to the joint's stiffness (eq 8).

The loaded static equilibrium (eq 1) is written in joint space::

    θ = D(τ(θ)),   τ(θ) = -g(q+θ) - M_c(q2+θ2) e2 + τ_ext(q+θ)

where ``D`` is the joint deflection law (``θ_j = k_j τ_j`` for linear joints),
``g`` the gravity torque of :meth:`Robot.gravity_torque` and ``τ_ext`` the
generalized force of the external load.  It is solved by Newton's method; the
Jacobian of the residual carries the Hessian terms of eq 3, which gives the
Cartesian stiffness at the loaded equilibrium.

External loads are wrenches ``[f (N); m (N·m)]`` referred to the flange origin
and expressed in the base axes.  By default the wrench is a dead load: it keeps
its value in the base axes while the arm deflects.  When a ``load_point`` is
given to :class:`ElasticArm`, its force acts at that material point of the tool (a hanging mass, as
in the paper's experiments) and only the remaining couple stays fixed, which
is the conservative load the twin applies.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from bayescal.robot.kinematics import Robot, Workspace

if TYPE_CHECKING:
    from bayescal.robot.laws import CompensatorLaw

__all__ = [
    "EquilibriumError",
    "JointLaw",
    "LinearJoints",
    "compliance_design",
    "joint_stiffness",
    "ElasticArm",
]

class EquilibriumError(RuntimeError):
    """Newton's method did not find the loaded static equilibrium."""


class JointLaw(Protocol):
    """How the joint springs deflect: ``θ = deflection(τ)`` joint by joint."""

    def deflection(self, torque: np.ndarray) -> np.ndarray:
        """(nq,) joint deflections (rad) under the joint torques ``torque`` (N·m)."""

    def slope(self, torque: np.ndarray) -> np.ndarray:
        """(nq,) derivatives ``dθ_j/dτ_j`` (rad/(N·m)) of :meth:`deflection`."""


class LinearJoints:
    """Linear virtual springs ``θ_j = k_j τ_j`` with compliances ``k`` in rad/(N·m)."""

    def __init__(self, compliances) -> None:
        self.compliances = _compliances(compliances)

    def deflection(self, torque: np.ndarray) -> np.ndarray:
        return self.compliances * torque

    def slope(self, torque: np.ndarray) -> np.ndarray:
        return self.compliances.copy()


def _compliances(compliances) -> np.ndarray:
    k = np.asarray(compliances, dtype=float)
    if k.ndim != 1 or not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise ValueError(f"joint compliances must be a vector of positive finite numbers in rad/(N·m), got {k}")
    return k


def compliance_design(robot: Robot | Workspace, q, point_in_flange, wrench) -> np.ndarray:
    """Matrix ``A`` of eq 31 for one marker: ``Δp ≈ A @ k`` for joint compliances ``k`` (rad/(N·m)).

    Parameters
    ----------
    robot
        The robot, or one of its workspaces (a loop over configurations passes its own).
    q
        (nq,) joint angles, rad.
    point_in_flange
        (3,) the marker in the flange frame, m.
    wrench
        (6,) ``[f; m]`` at the flange origin in base axes, N and N·m.

    Returns
    -------
    numpy.ndarray
        (3, nq); column ``j`` is ``J_p[:, j] (J_F[:, j] · wrench)`` where ``J_p`` is the
        marker's position Jacobian and ``J_F`` the flange Jacobian, so that
        ``A[:, j] k_j`` is the marker's displacement due to joint ``j``'s spring.
    """
    wrench = np.asarray(wrench, dtype=float).reshape(6)
    workspace = robot.workspace() if isinstance(robot, Robot) else robot
    torques = workspace.flange_jacobian(q).T @ wrench
    return workspace.point_jacobian(q, point_in_flange) * torques[np.newaxis, :]


def joint_stiffness(q, compliances, compensator: CompensatorLaw | None = None, joint: int | None = None) -> np.ndarray:
    """(nq, nq) joint stiffness ``K_θ(q)`` in N·m/rad: ``diag(1/k)`` plus the compensator on ``joint`` (0-based; eq 8).

    ``compliances[joint]`` is the compliance of that joint without its compensator, ``1/K_θ2^0``.
    """
    k = _compliances(compliances)
    stiffness = np.diag(1.0 / k)
    if compensator is not None:
        if joint is None:
            raise ValueError("a compensator needs the index of the joint it acts on")
        stiffness[joint, joint] += compensator.stiffness(float(np.asarray(q)[joint]))
    return stiffness


class _Load:
    """The external load as a force at a material point of the tool plus a dead couple."""

    def __init__(self, workspace: Workspace, q: np.ndarray, wrench, load_point) -> None:
        wrench = np.asarray(wrench, dtype=float).reshape(6)
        if not np.all(np.isfinite(wrench)):
            raise ValueError(f"the wrench must be finite, got {wrench}")
        self.point = np.zeros(3) if load_point is None else np.asarray(load_point, dtype=float).reshape(3)
        force = wrench[:3]
        rotation, _ = workspace.flange_pose(q)
        couple = wrench[3:] - np.cross(rotation @ self.point, force)
        self.generalized = np.concatenate([force, couple])
        self.workspace = workspace

    def torque(self, q: np.ndarray) -> np.ndarray:
        """Generalized force of the load with the arm at ``q``."""
        jacobian = np.vstack([self.workspace.point_jacobian(q, self.point), self.workspace.flange_jacobian(q)[3:]])
        return jacobian.T @ self.generalized

    def torque_derivative(self, q: np.ndarray) -> np.ndarray:
        """``∂τ_ext/∂q`` (nq, nq): the load's Hessian term of eq 3."""
        hessian = self.workspace.point_hessian(q, self.point)
        return np.einsum("r,rij->ij", self.generalized, hessian)


@dataclass(frozen=True)
class ElasticArm:
    """The virtual-joint model of one robot: everything the static equilibrium depends on but the pose and the load.

    One object carries the robot, its joint springs, the compensator, the
    links' weights and where a load's force acts, the way Pinocchio passes one
    model object, instead of the same arguments threaded through every solver.

    Parameters
    ----------
    robot
        The robot (kinematics and link masses).
    joints
        Deflection law of the joint springs (:class:`LinearJoints` for compliances
        ``k`` in rad/(N·m); the compensated joint's excludes the compensator).
    compensator
        The gravity compensator acting on the compensated joint, if any.
    gravity
        Include the links' weights.
    load_point
        (3,) flange-frame point (m) where a wrench's force acts and moves with the
        tool (a hanging mass); ``None`` keeps the whole wrench fixed at the flange origin.
    compensated_joint
        Index (0-based) of the joint the compensator acts on (the cell's
        :attr:`~bayescal.cell.config.Cell.compensated_joint`); required with a compensator.
    """

    robot: Robot
    joints: JointLaw
    compensator: CompensatorLaw | None = None
    gravity: bool = True
    load_point: np.ndarray | None = None
    compensated_joint: int | None = None

    def __post_init__(self) -> None:
        if self.compensator is not None and self.compensated_joint is None:
            raise ValueError("a compensator needs compensated_joint, the index of the joint it acts on (the cell's)")

    @classmethod
    def linear(cls, robot: Robot, compliances, **options) -> ElasticArm:
        """An arm with linear joint springs of compliances ``k`` (rad/(N·m)); ``options`` are the other fields."""
        return cls(robot, LinearJoints(compliances), **options)

    def equilibrium(self, q, wrench, *, tol: float = 1e-13, max_iter: int = 30) -> np.ndarray:
        """Joint deflections ``θ`` (rad) of the loaded static equilibrium (eq 1), by Newton's method.

        Parameters
        ----------
        q
            (nq,) commanded joint angles, rad.
        wrench
            (6,) external wrench ``[f; m]`` at the flange origin, base axes, N and N·m, as
            applied with the arm at ``q``.
        tol
            Convergence threshold on the Newton step, rad.
        max_iter
            Largest number of Newton iterations.

        Returns
        -------
        numpy.ndarray
            (nq,) deflections; the links are at ``q + θ``.

        Raises
        ------
        EquilibriumError
            When Newton's method does not converge (e.g. a load beyond the arm's buckling
            limit or a non-physical stiffness).
        """
        return self._solve(q, wrench, tol, max_iter)[0]

    def equilibrium_stiffness(self, q, wrench) -> tuple[np.ndarray, np.ndarray]:
        """Deflections ``θ`` and the joint-space stiffness ``K_θ - H_θθ`` (eq 3) at the loaded equilibrium.

        The stiffness is the derivative of the spring torques minus the load and
        gravity torques with respect to the link angles: the joint springs (with
        the compensator, eq 8) plus the Hessian terms of the links' weights and of
        the external load.
        """
        theta, torque, derivative = self._solve(q, wrench, tol=1e-13, max_iter=30)
        return theta, np.diag(1.0 / self.joints.slope(torque)) - derivative

    def cartesian_stiffness(self, q, wrench) -> np.ndarray:
        """(6, 6) Cartesian stiffness ``K_C`` of eq 3 at the loaded equilibrium.

        ``K_C`` maps a small displacement ``[δp; δφ]`` of the flange (m, rad, base axes)
        to the increment of a dead wrench ``[δf; δm]`` at the flange origin that causes it.
        For a robot with fewer than six joints the inverse does not exist; use the
        compliance ``J (K_θ - H)⁻¹ Jᵀ`` instead.
        """
        q = np.asarray(q, dtype=float)
        theta, stiffness = self.equilibrium_stiffness(q, wrench)
        jacobian = self.robot.flange_jacobian(q + theta)
        return np.linalg.inv(jacobian @ np.linalg.solve(stiffness, jacobian.T))

    def _joint_load(self, q: np.ndarray, theta: np.ndarray, load: _Load) -> tuple[np.ndarray, np.ndarray]:
        """Torque carried by the joint springs and its derivative with respect to θ (the negated Hessian terms)."""
        linked = q + theta
        torque = load.torque(linked)
        derivative = load.torque_derivative(linked)
        if self.gravity:
            torque = torque - load.workspace.gravity_torque(linked)
            derivative = derivative - load.workspace.gravity_torque_derivative(linked)
        if self.compensator is not None:
            j = self.compensated_joint
            angle = float(linked[j])
            torque[j] -= self.compensator.torque(angle)
            derivative[j, j] -= self.compensator.stiffness(angle)
        return torque, derivative

    def _solve(self, q, wrench, tol: float, max_iter: int):
        robot, law = self.robot, self.joints
        q = np.asarray(q, dtype=float).reshape(robot.nq)
        # One workspace per solve: the arm, shared by threads, holds none.
        load = _Load(robot.workspace(), q, wrench, self.load_point)
        theta = np.zeros(robot.nq)

        def residual(theta):
            torque, derivative = self._joint_load(q, theta, load)
            return theta - law.deflection(torque), torque, derivative

        value, torque, derivative = residual(theta)
        for _ in range(max_iter):
            jacobian = np.eye(robot.nq) - law.slope(torque)[:, np.newaxis] * derivative
            try:
                step = -np.linalg.solve(jacobian, value)
            except np.linalg.LinAlgError:
                raise EquilibriumError("the linearised equilibrium is singular (the arm buckles under this load)") from None
            # Backtracking keeps Newton stable on steep deflection laws such as a backlash dead band.
            size = 1.0
            while True:
                candidate = residual(theta + size * step)
                if np.linalg.norm(candidate[0]) < np.linalg.norm(value) or size < 1e-4:
                    break
                size *= 0.5
            theta = theta + size * step
            value, torque, derivative = candidate
            # The full Newton step, not the backtracked one, says whether the solve has settled.
            if np.max(np.abs(step)) < tol or np.max(np.abs(value)) < tol:
                return theta, torque, derivative
        raise EquilibriumError(
            f"Newton's method did not converge in {max_iter} iterations (last residual {np.max(np.abs(value)):.3g} rad)"
        )
