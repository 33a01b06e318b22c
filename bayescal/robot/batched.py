"""Kinematics and static equilibria of many configurations at once, as stacked numpy arrays.

Pinocchio computes one configuration per call, and for a large campaign the
Python cost of each call, not the arithmetic, sets the exact model's time.
:class:`BatchedChain` reads the chain from the robot's Pinocchio model once
(each joint's placement in its parent, its axis from the joint's motion
subspace, each body's mass and centre of mass, the flange's placement, the
gravity vector) and evaluates, for ``N`` configurations in one pass of array
operations, what :class:`~bayescal.robot.stiffness.ElasticArm` asks of a
:class:`~bayescal.robot.kinematics.Workspace`: the flange's pose, the Jacobian
of a point of the flange body, the load's Hessian term of eq 3, and the
gravity torque ``g(q)`` with its derivative.  :func:`equilibria` is the
Newton solve of eq 1 for linear joint springs, for all configurations together.

The conventions are those of :mod:`bayescal.robot.kinematics`; every quantity
is checked against Pinocchio's in the tests.  Each joint moves the bodies of
its subtree rigidly, so derivatives of Jacobian columns are cross products with
the axes: ``∂/∂q_j`` of a vector fixed to the bodies after a revolute joint
``j`` is ``z_j ×`` that vector, and a prismatic joint turns nothing.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

from bayescal.robot.kinematics import Robot
from bayescal.robot.stiffness import EquilibriumError

if TYPE_CHECKING:
    from bayescal.robot.laws import CompensatorLaw

__all__ = ["BatchedChain", "Poses", "equilibria"]


@dataclass(frozen=True)
class Poses:
    """The joint frames of ``N`` configurations (base frame, m).

    Attributes
    ----------
    axes : numpy.ndarray
        ``(N, nq, 3)`` unit axis of each joint.
    origins : numpy.ndarray
        ``(N, nq, 3)`` origin of each joint frame, on a revolute joint's axis.
    com : numpy.ndarray
        ``(N, nq, 3)`` centre of mass of each joint's body.
    flange_rotation, flange_origin : numpy.ndarray
        ``(N, 3, 3)`` and ``(N, 3)`` the flange frame.
    """

    axes: np.ndarray
    origins: np.ndarray
    com: np.ndarray
    flange_rotation: np.ndarray
    flange_origin: np.ndarray

    def points(self, in_flange: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """``(M, 3)`` base-frame positions of flange-frame points ``(M, 3)`` or ``(3,)``, m.

        ``rows`` ``(M,)`` names each point's configuration (a campaign's rows, say); None: one point per configuration.
        """
        rotation, origin = (self.flange_rotation, self.flange_origin) if rows is None else (self.flange_rotation[rows], self.flange_origin[rows])
        return np.einsum("nij,nj->ni", rotation, np.broadcast_to(in_flange, origin.shape)) + origin

    def take(self, rows: np.ndarray) -> Poses:
        """The frames of the configurations ``rows`` (indices or a bool mask): each configuration's frames are its own,
        so they are those :meth:`BatchedChain.poses` gives of those configurations alone, bit for bit."""
        return Poses(**{field.name: getattr(self, field.name)[rows] for field in fields(Poses)})

    def in_flange(self, in_base: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """``(M, 3)`` flange-frame coordinates of base-frame points ``(M, 3)``: the inverse of :meth:`points`."""
        rotation, origin = (self.flange_rotation, self.flange_origin) if rows is None else (self.flange_rotation[rows], self.flange_origin[rows])
        return np.einsum("nij,ni->nj", rotation, in_base - origin)


def _times(stack: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """``stack @ matrix`` for a stack ``(N, 3, 3)`` and one matrix ``(3, 3)`` or vector ``(3,)``.

    One 2-D product over the stacked rows: numpy's batched ``matmul`` of 3 × 3
    matrices runs a small loop per matrix, about 25 times slower at N = 10,000.
    """
    return (stack.reshape(-1, 3) @ matrix).reshape(stack.shape[:-1] + matrix.shape[1:])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of vectors on the last axis (both of length 3), broadcast, bit for bit the same products and
    differences, without np.cross's axis handling, which dominates its calls on these stacks: 1.5 to 3 times faster
    on stacks of 20 to 2,000 configurations."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _turns(axis: np.ndarray) -> np.ndarray:
    """``(2, 3, 3)`` the cross-product matrix ``K`` of the unit ``axis`` and ``K @ K``: Rodrigues' formula's."""
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.stack([cross, cross @ cross])


def _turned(stack: np.ndarray, turns: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``stack @ R`` for rotations ``R`` by ``angle`` (rad, ``(N,)``) about an axis of :func:`_turns` ``turns`` (Rodrigues' formula)."""
    sin, cos = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return stack + sin * _times(stack, turns[0]) + (1.0 - cos) * _times(stack, turns[1])


@dataclass(frozen=True)
class BatchedChain:
    """The chain of a :class:`~bayescal.robot.kinematics.Robot` as arrays (:meth:`of` builds it; SI).

    Attributes
    ----------
    parents : numpy.ndarray
        ``(nq,)`` parent joint of each joint, -1 for the base.
    rotations, translations : numpy.ndarray
        ``(nq, 3, 3)`` and ``(nq, 3)`` each joint's placement in its parent's frame.
    axes : numpy.ndarray
        ``(nq, 3)`` each joint's axis in its own frame.
    prismatic : numpy.ndarray
        ``(nq,)`` bool.
    masses, levers : numpy.ndarray
        ``(nq,)`` kg and ``(nq, 3)`` m: each joint's body, its centre of mass in the joint's frame.
    flange_joint : int
        Joint (0-based) the flange is fixed to.
    flange_rotation, flange_translation : numpy.ndarray
        The flange's placement in that joint's frame.
    gravity : numpy.ndarray
        ``(3,)`` acceleration of gravity, m/s².
    support : numpy.ndarray
        ``(nq, nq)`` bool, ``support[a, d]`` when joint ``a`` is ``d`` or one of its ancestors.
    turns : numpy.ndarray
        ``(nq, 2, 3, 3)`` each joint's :func:`_turns`, built once: a plan search calls :meth:`poses` over a thousand times
        (1,314 in ``bayescal plan --model linear``).
    """

    parents: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray
    axes: np.ndarray
    prismatic: np.ndarray
    masses: np.ndarray
    levers: np.ndarray
    flange_joint: int
    flange_rotation: np.ndarray
    flange_translation: np.ndarray
    gravity: np.ndarray
    support: np.ndarray
    turns: np.ndarray

    @classmethod
    def of(cls, robot: Robot) -> BatchedChain:
        """Read ``robot``'s Pinocchio model (masses as they are, e.g. after :func:`~bayescal.inference.exact.scale_masses`)."""
        model = robot.model
        nq = robot.nq
        axes = np.empty((nq, 3))
        for i, joint in enumerate(list(model.joints)[1:]):
            data = joint.createData()
            joint.calc(data, np.zeros(1))
            motion = np.asarray(data.S).ravel()
            axes[i] = motion[:3] if robot.prismatic[i] else motion[3:]
        parents = np.array([int(p) - 1 for p in list(model.parents)[1:]])
        support = np.eye(nq, dtype=bool)
        for d in range(nq):
            a = parents[d]
            while a >= 0:
                support[a, d] = True
                a = parents[a]
        placements = list(model.jointPlacements)[1:]
        inertias = list(model.inertias)[1:]
        flange = model.frames[model.getFrameId(robot.flange)]
        return cls(
            parents=parents,
            rotations=np.array([p.rotation for p in placements]),
            translations=np.array([p.translation for p in placements]),
            axes=axes,
            prismatic=robot.prismatic.copy(),
            masses=np.array([inertia.mass for inertia in inertias]),
            levers=np.array([inertia.lever for inertia in inertias]),
            flange_joint=int(flange.parentJoint) - 1,
            flange_rotation=np.array(flange.placement.rotation),
            flange_translation=np.array(flange.placement.translation),
            gravity=np.array(model.gravity.linear),
            support=support,
            turns=np.array([_turns(axis) for axis in axes]),
        )

    def poses(self, q: np.ndarray) -> Poses:
        """The frames of the ``(N, nq)`` configurations ``q`` (rad or m), :data:`CHUNK` configurations at a time.

        Each configuration's frames are computed alone, so the chunks change no bit; their arrays stay in the
        processor's cache: 200,000 configurations in 0.15-0.37 s of CPU, joined, instead of 0.94 s at once.
        """
        if len(q) <= CHUNK:
            return self._poses(q)
        parts = [self._poses(q[start : start + CHUNK]) for start in range(0, len(q), CHUNK)]
        return Poses(**{field.name: np.concatenate([getattr(part, field.name) for part in parts]) for field in fields(Poses)})

    def _poses(self, q: np.ndarray) -> Poses:
        n, nq = q.shape
        rotations, origins, axes, com = [], [], [], []
        for i in range(nq):
            parent = self.parents[i]
            if parent < 0:
                rotation, origin = np.broadcast_to(self.rotations[i], (n, 3, 3)), np.broadcast_to(self.translations[i], (n, 3))
            else:
                rotation = _times(rotations[parent], self.rotations[i])
                origin = origins[parent] + _times(rotations[parent], self.translations[i])
            # A joint turns about, or slides along, its own axis: the axis is the same before and after the motion.
            axes.append(_times(rotation, self.axes[i]))
            if self.prismatic[i]:
                rotations.append(rotation)
                origins.append(origin + axes[i] * q[:, i, None])
            else:
                rotations.append(_turned(rotation, self.turns[i], q[:, i]))
                origins.append(origin)
            com.append(origins[i] + _times(rotations[i], self.levers[i]))
        f = self.flange_joint
        return Poses(
            axes=np.stack(axes, axis=1),
            origins=np.stack(origins, axis=1),
            com=np.stack(com, axis=1),
            flange_rotation=_times(rotations[f], self.flange_rotation),
            flange_origin=origins[f] + _times(rotations[f], self.flange_translation),
        )

    def point_jacobian(self, poses: Poses, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Linear and angular Jacobians ``(N, nq, 3)`` (one row per joint) of base-frame points ``(N, 3)`` on the flange body."""
        on_path = self.support[:, self.flange_joint]
        revolute = (~self.prismatic & on_path)[None, :, None]
        linear = np.where(revolute, _cross(poses.axes, point[:, None, :] - poses.origins), 0.0)
        linear = np.where((self.prismatic & on_path)[None, :, None], poses.axes, linear)
        return linear, np.where(revolute, poses.axes, 0.0)

    def load_torque(self, poses: Poses, point: np.ndarray, generalized: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Generalized force ``(N, nq)`` of a load ``[f; couple]`` ``(N, 6)`` acting at ``point`` ``(N, 3)`` on the
        flange body, and its derivative ``(N, nq, nq)`` with respect to the joints (the load's Hessian term of eq 3)."""
        linear, angular = self.point_jacobian(poses, point)
        force, couple = generalized[:, None, :3], generalized[:, None, 3:]
        torque = (linear @ np.swapaxes(force, 1, 2) + angular @ np.swapaxes(couple, 1, 2))[:, :, 0]
        revolute = ~self.prismatic
        # Column i after joint j (j its ancestor or itself) turns with j: d/dq_j = z_j × column.
        # (Batched matmul, not einsum, for these small products: four times faster at N = 10,000.)
        after = (_cross(linear, force) + _cross(angular, couple)) @ np.swapaxes(poses.axes, 1, 2)
        after = np.where((self.support.T & revolute[None, :])[None], after, 0.0)
        # Column i of a revolute joint before joint j: the point moves, the axis stays.
        before = poses.axes @ np.swapaxes(_cross(linear, force), 1, 2)
        before = np.where((self.support & ~np.eye(self.support.shape[0], dtype=bool) & revolute[:, None])[None], before, 0.0)
        return torque, after + before

    def gravity_torque(self, poses: Poses) -> tuple[np.ndarray, np.ndarray]:
        """Pinocchio's ``g(q)`` ``(N, nq)`` (N·m) and its symmetric derivative ``∂g/∂q`` ``(N, nq, nq)``."""
        moment = self.support.astype(float) @ (self.masses[None, :, None] * poses.com)
        subtree_mass = self.support.astype(float) @ self.masses
        lever = moment - subtree_mass[None, :, None] * poses.origins
        # How each joint's subtree moves its weight's application: z × (moment about the axis), or the mass along a slide.
        moved = np.where(self.prismatic[None, :, None], subtree_mass[None, :, None] * poses.axes, _cross(poses.axes, lever))
        torque = -moved @ self.gravity
        # T[a, d] = ∂g_d/∂q_a for a revolute joint a before d (or d itself).
        T = -(poses.axes @ np.swapaxes(_cross(moved, self.gravity), 1, 2))
        T = np.where((self.support & ~self.prismatic[:, None])[None], T, 0.0)
        diagonal = np.einsum("nii->ni", T)
        derivative = T + np.swapaxes(T, 1, 2)
        derivative[:, np.arange(T.shape[1]), np.arange(T.shape[1])] -= diagonal
        return torque, derivative


@dataclass(frozen=True)
class _Loads:
    """The loads of ``N`` configurations as :class:`~bayescal.robot.stiffness.ElasticArm` applies them: a force at a
    material point of the tool and the remaining couple, fixed in the base axes (``(N, 3)`` point, ``(N, 6)`` load)."""

    point: np.ndarray
    generalized: np.ndarray

    def take(self, index: np.ndarray) -> _Loads:
        return _Loads(self.point[index], self.generalized[index])


def _loads(chain: BatchedChain, q: np.ndarray, wrench: np.ndarray, load_point: np.ndarray | None) -> _Loads:
    n = q.shape[0]
    wrench = np.broadcast_to(np.asarray(wrench, dtype=float), (n, 6))
    if not np.all(np.isfinite(wrench)):
        raise ValueError("the wrenches must be finite")
    point = np.zeros((n, 3)) if load_point is None else np.broadcast_to(np.asarray(load_point, dtype=float), (n, 3))
    force = wrench[:, :3]
    couple = np.array(wrench[:, 3:])
    # The couple of a load of +0.0 throughout is +0.0 wherever its point is: the flange's pose is needed for the others
    # alone (the unloaded half of a simulated campaign's solves)
    loaded = np.flatnonzero(~np.all((wrench == 0.0) & ~np.signbit(wrench), axis=1))
    if loaded.size:
        rotation = chain.poses(q[loaded]).flange_rotation
        couple[loaded] = wrench[loaded, 3:] - _cross(np.einsum("nij,nj->ni", rotation, point[loaded]), force[loaded])
    return _Loads(np.array(point), np.concatenate([force, couple], axis=1))


@dataclass(frozen=True)
class _Springs:
    """What the springs and the compensator add to the equilibrium of ``N`` configurations."""

    compliances: np.ndarray
    compensator: CompensatorLaw | None
    joint: int | None
    gravity: bool
    spring: np.ndarray | None = None

    def take(self, index: np.ndarray) -> _Springs:
        return _Springs(self.compliances[index], self.compensator, self.joint, self.gravity, None if self.spring is None else self.spring[index])


def _joint_load(chain: BatchedChain, q: np.ndarray, theta: np.ndarray, loads: _Loads, springs: _Springs):
    """Torques ``(N, nq)`` carried by the joint springs and their derivatives ``(N, nq, nq)`` with respect to θ."""
    linked = q + theta
    poses = chain.poses(linked)
    point = poses.points(loads.point)
    torque, derivative = chain.load_torque(poses, point, loads.generalized)
    if springs.gravity:
        weight, weight_derivative = chain.gravity_torque(poses)
        torque, derivative = torque - weight, derivative - weight_derivative
    if springs.compensator is not None:
        j = springs.joint
        if springs.spring is None:
            torque[:, j] -= springs.compensator.torque(linked[:, j])
            derivative[:, j, j] -= springs.compensator.stiffness(linked[:, j])
        else:
            torque[:, j] -= springs.compensator.torque_of(springs.spring, linked[:, j])
            derivative[:, j, j] -= springs.compensator.stiffness_of(springs.spring, linked[:, j])
    return torque, derivative


def equilibria(
    chain: BatchedChain,
    q: np.ndarray,
    wrench: np.ndarray,
    compliances: np.ndarray,
    *,
    compensator: CompensatorLaw | None = None,
    compensated_joint: int | None = None,
    load_point: np.ndarray | None = None,
    gravity: bool = True,
    springs: np.ndarray | None = None,
    tol: float = 1e-13,
    max_iter: int = 30,
) -> np.ndarray:
    """Joint deflections ``θ`` (rad or m) of the loaded static equilibria (eq 1) of ``N`` configurations.

    The same Newton iteration, backtracking and stopping rule as
    :meth:`ElasticArm.equilibrium <bayescal.robot.stiffness.ElasticArm.equilibrium>` with
    linear joint springs, run on all configurations at once; each stops when its own solve has settled.

    Parameters
    ----------
    chain
        The robot's chain (:meth:`BatchedChain.of`).
    q
        ``(N, nq)`` commanded joint positions, rad or m.
    wrench
        ``(N, 6)`` or ``(6,)`` load ``[f; m]`` at the flange origin, base axes, N and N·m, as applied at ``q``.
    compliances
        ``(N, nq)`` or ``(nq,)`` joint compliances, rad/(N·m) or m/N; the compensated joint's excludes the compensator.
    compensator, compensated_joint
        The compensator and the joint (0-based) it acts on; None without one.
    load_point
        ``(N, 3)`` or ``(3,)`` flange-frame point (m) where the force acts; None: the flange origin.
    gravity
        Include the links' weights.
    springs
        ``(N, p)`` or ``(p,)`` each configuration's values of the compensator law's parameters (SI; the spring's
        ``[K_c, s0]``, N/m and m) in place of ``compensator``'s, whose linkage stays: many variants solved in one
        call; None: ``compensator``'s own.
    tol, max_iter
        Convergence threshold on the Newton step (rad) and the largest number of iterations.

    Returns
    -------
    numpy.ndarray
        ``(N, nq)`` deflections; the links are at ``q + θ``.

    Raises
    ------
    EquilibriumError
        When a linearised equilibrium is singular or a solve does not settle in ``max_iter`` iterations.
    """
    q = np.asarray(q, dtype=float)
    joint_springs = _checked_springs(q, compliances, compensator, compensated_joint, gravity, springs)
    return _solve_in_chunks(chain, q, _loads(chain, q, wrench, load_point), joint_springs, tol, max_iter)


def _checked_springs(q: np.ndarray, compliances, compensator: CompensatorLaw | None, compensated_joint: int | None, gravity: bool,
                     springs) -> _Springs:
    """The joints' springs of :func:`equilibria`'s arguments, refusing non-positive compliances and a half-given compensator."""
    k = np.broadcast_to(np.asarray(compliances, dtype=float), q.shape)
    if not np.all(np.isfinite(k) & (k > 0)):
        raise ValueError("joint compliances must be positive finite numbers in rad/(N·m)")
    if compensator is not None and compensated_joint is None:
        raise ValueError("a compensator needs compensated_joint, the index of the joint it acts on")
    if springs is not None:
        if compensator is None:
            raise ValueError("springs replace a compensator's spring: give the compensator too")
        springs = np.array(np.broadcast_to(np.asarray(springs, dtype=float), (len(q), len(compensator.PARAMETERS))))
    return _Springs(np.array(k), compensator, compensated_joint, gravity, springs)


def _solve_in_chunks(chain: BatchedChain, q: np.ndarray, loads, springs, tol: float, max_iter: int) -> np.ndarray:
    """``(N, nq)`` the equilibria's deflections, :data:`CHUNK` configurations per Newton solve."""
    n = len(q)
    result = np.empty(q.shape)
    for start in range(0, n, CHUNK):
        part = np.arange(start, min(start + CHUNK, n))
        try:
            result[part] = _newton(chain, q[part], loads.take(part), springs.take(part), tol, max_iter)
        except _Unsettled as unsettled:
            first, residual = unsettled.args
            raise EquilibriumError(
                f"Newton's method did not converge in {max_iter} iterations for some of {n} configurations "
                f"(the first: {start + first}; last residual {residual:.3g} rad)"
            ) from None
    return result


CHUNK = 2048
"""Configurations solved together: the arrays of a chunk stay in the processor's cache.  Measured on the
KR-270 (one core): 7.8 μs a configuration's equilibrium in chunks of 2,000, 8.5 μs of 1,000, 9.5 μs of
10,000 and 11 μs of 40,000."""


class _Unsettled(Exception):
    """A chunk's solve did not settle: the first unsettled configuration of the chunk and the largest residual."""


def _newton(chain: BatchedChain, q: np.ndarray, loads: _Loads, springs: _Springs, tol: float, max_iter: int) -> np.ndarray:
    """The Newton iteration of :func:`equilibria` on one chunk of configurations."""
    n, nq = q.shape
    result = np.empty((n, nq))
    active = np.arange(n)
    theta = np.zeros((n, nq))
    torque, derivative = _joint_load(chain, q, theta, loads, springs)
    value = theta - springs.compliances * torque
    for _ in range(max_iter):
        jacobian = np.eye(nq) - springs.compliances[:, :, None] * derivative
        try:
            step = -np.linalg.solve(jacobian, value[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            raise EquilibriumError("the linearised equilibrium is singular (the arm buckles under this load)") from None
        size, candidate = _backtrack(chain, q[active], theta, step, value, loads, springs)
        theta = theta + size[:, None] * step
        torque, derivative, value = candidate
        # The full Newton step, not the backtracked one, says whether a solve has settled.
        settled = (np.max(np.abs(step), axis=1) < tol) | (np.max(np.abs(value), axis=1) < tol)
        result[active[settled]] = theta[settled]
        if settled.all():
            return result
        keep = ~settled
        active, theta, torque, derivative, value = active[keep], theta[keep], torque[keep], derivative[keep], value[keep]
        loads, springs = loads.take(keep), springs.take(keep)
    raise _Unsettled(int(active[0]), float(np.max(np.abs(value))))


def _backtrack(chain, q, theta, step, value, loads: _Loads, springs: _Springs):
    """Step sizes ``(N,)`` that lower each residual's norm (halved from 1 down to below 1e-4) and the residuals there."""
    size = np.ones(q.shape[0])
    torque, derivative = _joint_load(chain, q, theta + step, loads, springs)
    candidate = theta + step - springs.compliances * torque
    start = np.linalg.norm(value, axis=1)
    while True:
        retry = np.flatnonzero(~((np.linalg.norm(candidate, axis=1) < start) | (size < 1e-4)))
        if retry.size == 0:
            return size, (torque, derivative, candidate)
        # Backtracking keeps Newton stable on steep deflection laws, as the one-configuration solver.
        size[retry] *= 0.5
        moved = theta[retry] + size[retry, None] * step[retry]
        t, d = _joint_load(chain, q[retry], moved, loads.take(retry), springs.take(retry))
        torque[retry], derivative[retry] = t, d
        candidate[retry] = moved - springs.compliances[retry] * t
