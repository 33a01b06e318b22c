"""Inverse kinematics of the flange: joints that put the flange at given poses, in a given configuration.

The solve is the damped least-squares closed-loop scheme of Pinocchio's inverse
kinematics example (``examples/inverse-kinematics.py``: the pose error as a
twist, ``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e``), run on every target at once with the
stacked kinematics of :class:`~bayescal.robot.batched.BatchedChain` (checked
against Pinocchio's in the tests), because a program of 10,000 targets costs
10,000 times the Python overhead of one Pinocchio call per iteration otherwise.

A 6-axis arm reaches most poses in up to eight configurations; which one the
program means is told by the controller (KUKA's status bits, ABB's ``cfx``) as a
*class* of solutions: ``classify(q)`` gives each solution's class, and the solve
starts each target from the seeds of its class closest to it
(:data:`SEEDS` configurations drawn once within the joint limits), keeping the
first solution found in the right class.  A target none of whose tries converges
is out of reach; one whose tries converge only in other classes would flip the arm.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bayescal.robot.batched import BatchedChain
from bayescal.robot.kinematics import Robot

__all__ = ["InverseSolution", "inverse_kinematics", "wrap_angles", "SEEDS", "POSITION_TOLERANCE", "ORIENTATION_TOLERANCE"]

POSITION_TOLERANCE = 1e-9
"""Flange position residual (m) of a solved target: a thousandth of the 0.1 μm the controllers' 4 decimals of mm resolve."""

ORIENTATION_TOLERANCE = 1e-9
"""Flange orientation residual (rad): 1e-9 rad turns a tool point 0.5 m out by 0.5 nm."""

DAMPING = 1e-6
"""λ of the damped least squares (m, rad): negligible beside the KR-270's Jacobian singular values away from a
singularity (tenths to metres), it keeps a step bounded where the wrist is stretched."""

MAX_STEP = 0.5
"""Largest joint step of one iteration (rad, norm over the joints): a seed up to a radian away then converges
instead of overshooting into another configuration."""

MAX_ITERATIONS = 30
"""Iterations per try.  Measured on 10,000 random KR-270 targets from the nearest seed of their class: 64 % have
converged after 8 iterations, 91 % after 12, 99.6 % after 20, 99.76 % after 30 and no more after 60 (the rest
converge from another seed)."""

SEEDS = 4096
"""Configurations of the seed bank: the KR-270's eight status classes get 108 to 1,107 of them."""

TRIES = 16
"""Seeds tried per target, nearest first, before it is declared out of reach or flipping.  Measured on 20,000
random KR-270 targets: 4 tries leave 12 unsolved in their status class, 8 leave 1, 16 none; a try after the
first runs only on the targets still unsolved."""

ORIENTATION_WEIGHT = 1.0
"""m per rad: how a seed's orientation distance counts against its position distance when seeds are ranked
(a radian of turn is worth a metre, the length of a forearm)."""

_CHUNK = 1024
"""Targets ranked against the seed bank at once: a ``_CHUNK × SEEDS`` distance table (32 MB)."""


@dataclass(frozen=True)
class InverseSolution:
    """Joints of ``N`` targets.

    Attributes
    ----------
    q : numpy.ndarray
        ``(N, n)`` joints (rad or m), revolute joints in (-π, π]; NaN where not solved.
    reached : numpy.ndarray
        ``(N,)`` True where some try converged (in any class).
    kept : numpy.ndarray
        ``(N,)`` True where a try converged in the wanted class (``q`` is that solution).
    found : numpy.ndarray
        ``(N,)`` the class of the converged solution where only other classes were reached, else -1.
    """

    q: np.ndarray
    reached: np.ndarray
    kept: np.ndarray
    found: np.ndarray


def wrap_angles(robot: Robot, q: np.ndarray) -> np.ndarray:
    """``q`` with every revolute joint's angle brought into (-π, π]."""
    revolute = ~robot.prismatic
    out = np.array(q, dtype=float)
    out[:, revolute] = np.pi - np.mod(np.pi - out[:, revolute], 2 * np.pi)
    return out


def _rotation_vectors(rotation: np.ndarray) -> np.ndarray:
    """``(N, 3)`` rotation vectors (rad) of ``(N, 3, 3)`` rotations: Pinocchio's ``log3``."""
    trace = np.einsum("nii->n", rotation)
    angle = np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0))
    skew = np.stack([rotation[:, 2, 1] - rotation[:, 1, 2], rotation[:, 0, 2] - rotation[:, 2, 0], rotation[:, 1, 0] - rotation[:, 0, 1]], axis=1)
    sine = np.sin(angle)
    # angle / sin(angle) -> 1 at 0; near π the skew part vanishes and the direction is poor, but a step still turns the right way.
    factor = np.where(sine > 1e-9, angle / np.maximum(sine, 1e-9), 1.0) / 2.0
    return skew * factor[:, None]


def _solve(chain: BatchedChain, rotation: np.ndarray, origin: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Damped least squares from ``q`` ``(N, n)``; returns the joints and ``(N,)`` True where converged."""
    q = q.copy()
    converged = np.zeros(len(q), dtype=bool)
    active = np.arange(len(q))
    identity = np.eye(6) * DAMPING**2
    for _ in range(MAX_ITERATIONS):
        poses = chain.poses(q[active])
        position_error = origin[active] - poses.flange_origin
        turn_error = _rotation_vectors(rotation[active] @ np.swapaxes(poses.flange_rotation, 1, 2))
        done = (np.linalg.norm(position_error, axis=1) < POSITION_TOLERANCE) & (np.linalg.norm(turn_error, axis=1) < ORIENTATION_TOLERANCE)
        converged[active[done]] = True
        keep = ~done
        active = active[keep]
        if not active.size:
            break
        linear, angular = chain.point_jacobian(poses, poses.flange_origin)
        jacobian = np.concatenate([linear[keep], angular[keep]], axis=2).transpose(0, 2, 1)
        error = np.concatenate([position_error[keep], turn_error[keep]], axis=1)
        step = (np.swapaxes(jacobian, 1, 2) @ np.linalg.solve(jacobian @ np.swapaxes(jacobian, 1, 2) + identity, error[..., None]))[..., 0]
        size = np.linalg.norm(step, axis=1, keepdims=True)
        q[active] += step * np.minimum(1.0, MAX_STEP / np.maximum(size, 1e-300))
    return q, converged


def inverse_kinematics(
    robot: Robot,
    rotation: np.ndarray,
    origin: np.ndarray,
    wanted: np.ndarray,
    classify: Callable[[np.ndarray], np.ndarray],
) -> InverseSolution:
    """Joints that put the flange at ``N`` poses, each in the configuration class it names.

    Parameters
    ----------
    robot
        The robot (its nominal model: the controller's).
    rotation, origin
        ``(N, 3, 3)`` and ``(N, 3)`` the flange's wanted poses in the base frame (m).
    wanted
        ``(N,)`` the class each target must be reached in (what ``classify`` returns).
    classify
        ``(M, n)`` joints → ``(M,)`` integer class, for joints wrapped by :func:`wrap_angles`.

    Returns
    -------
    InverseSolution
    """
    chain = BatchedChain.of(robot)
    rotation = np.asarray(rotation, dtype=float)
    origin = np.asarray(origin, dtype=float)
    wanted = np.asarray(wanted)
    seeds = _seed_bank(robot)
    seed_poses = chain.poses(seeds)
    seed_class = classify(seeds)
    order = np.zeros((len(origin), TRIES), dtype=int)
    for kind in np.unique(wanted):
        targets = np.flatnonzero(wanted == kind)
        members = np.flatnonzero(seed_class == kind)
        if members.size < TRIES:
            continue  # a class the arm has no seeds in: every try fails, and the target is reported
        order[targets] = members[_nearest(origin[targets], rotation[targets], seed_poses.flange_origin[members], seed_poses.flange_rotation[members])]
    q = np.full((len(origin), robot.nq), np.nan)
    reached = np.zeros(len(origin), dtype=bool)
    kept = np.zeros(len(origin), dtype=bool)
    found = np.full(len(origin), -1)
    for attempt in range(TRIES):
        todo = np.flatnonzero(~kept)
        if not todo.size:
            break
        solved, converged = _solve(chain, rotation[todo], origin[todo], seeds[order[todo, attempt]])
        solved = wrap_angles(robot, solved)
        right = converged & (classify(solved) == wanted[todo])
        q[todo[right]] = solved[right]
        kept[todo[right]] = True
        reached[todo[converged]] = True
        wrong = converged & ~right
        if wrong.any():
            found[todo[wrong]] = classify(solved[wrong])
    _retry_in_any_class(chain, robot, (rotation, origin), (seeds, seed_poses), classify, reached, found)
    found[kept] = -1
    return InverseSolution(q=q, reached=reached, kept=kept, found=found)


def _retry_in_any_class(chain: BatchedChain, robot: Robot, targets: tuple[np.ndarray, np.ndarray], bank: tuple,
                        classify: Callable[[np.ndarray], np.ndarray], reached: np.ndarray, found: np.ndarray) -> None:
    """Try the targets no try reached in their class from the nearest seeds of any class (updating ``reached`` and ``found``).

    This tells a pose out of reach from one only another configuration reaches.
    """
    rotation, origin = targets
    seeds, seed_poses = bank
    lost = np.flatnonzero(~reached)
    if not lost.size:
        return
    anywhere = _nearest(origin[lost], rotation[lost], seed_poses.flange_origin, seed_poses.flange_rotation)
    for attempt in range(TRIES):
        todo = lost[~reached[lost]]
        if not todo.size:
            break
        solved, converged = _solve(chain, rotation[todo], origin[todo], seeds[anywhere[np.searchsorted(lost, todo), attempt]])
        solved = wrap_angles(robot, solved)
        reached[todo[converged]] = True
        if converged.any():
            found[todo[converged]] = classify(solved[converged])


def _nearest(origin: np.ndarray, rotation: np.ndarray, seed_origin: np.ndarray, seed_rotation: np.ndarray) -> np.ndarray:
    """``(N, TRIES)`` the seeds nearest each target, nearest first (:data:`ORIENTATION_WEIGHT` weighing turns)."""
    flat = seed_rotation.reshape(-1, 9).T
    squares = np.einsum("mi,mi->m", seed_origin, seed_origin)
    out = np.empty((len(origin), TRIES), dtype=int)
    for start in range(0, len(origin), _CHUNK):
        part = slice(start, start + _CHUNK)
        # Squared distances by products (the norms of differences would build a _CHUNK × seeds × 3 array):
        # 3 - tr(Rᵀ S) = 2 (1 - cos θ), about θ² for the small turns that rank the nearest seeds.
        distance = (
            np.einsum("ni,ni->n", origin[part], origin[part])[:, None]
            + squares[None, :]
            - 2.0 * origin[part] @ seed_origin.T
            + ORIENTATION_WEIGHT**2 * (3.0 - rotation[part].reshape(-1, 9) @ flat)
        )
        nearest = np.argpartition(distance, TRIES - 1, axis=1)[:, :TRIES]
        ranked = np.take_along_axis(distance, nearest, axis=1)
        out[part] = np.take_along_axis(nearest, np.argsort(ranked, axis=1), axis=1)
    return out


SEED_BANK_SEED = 20240601
"""Seed of the seed bank's draw: fixed, so that a program solves to the same joints in every run."""


def _seed_bank(robot: Robot) -> np.ndarray:
    """``(SEEDS, n)`` configurations drawn uniformly within the joint limits, revolute joints wrapped."""
    rng = np.random.default_rng(SEED_BANK_SEED)
    low = np.maximum(robot.lower, np.where(robot.prismatic, robot.lower, -np.pi))
    high = np.minimum(robot.upper, np.where(robot.prismatic, robot.upper, np.pi))
    return rng.uniform(low, high, (SEEDS, robot.nq))
