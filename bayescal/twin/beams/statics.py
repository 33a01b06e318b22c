"""Static equilibrium of the arm under gravity, its compensator and a hanging mass, by fixed-point iteration.

Given the joints' deflections and the elements' deformations, the chain's frames follow
(:func:`frames`); from the frames, every load's place, the compensator's length and so
each joint's torque and each element's wrench follow; the joints' laws and the elements'
compliances give the next deflections.  The loads move with the arm they load (the
hanging mass stays vertical, its point moves with the tool; the spring's line of action
turns with the lever), so the fixed point is the large-displacement equilibrium, not a
linearisation.  The iteration is a contraction because the arm is stiff against its
loads' change of place (on Table III under 280 kg the change per iteration falls 200- to
500-fold); it stops when no deflection changes by more than :data:`TOLERANCE`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayescal.twin.beams.robot import Item, Robot, rotation

__all__ = ["Equilibrium", "frames", "solve", "TOLERANCE", "MAX_ITERATIONS"]

TOLERANCE = 1e-12
"""Largest change of a deflection (rad or m) at which the iteration stops: a picometre, a millionth of the
tracker's noise and far above the rounding of the frames (about 1e-15 m on a 3 m arm)."""
MAX_ITERATIONS = 60
"""Iterations before the solve gives up; measured: 4 to 6 suffice on the Table III plan, unloaded and under 280 kg."""
GRAVITY_DIRECTION = np.array([0.0, 0.0, -1.0])
"""Down, in the base frame (its z axis is up)."""


@dataclass(frozen=True)
class Equilibrium:
    """The arm at rest: frames, deflections, torques and how well the equations hold.

    Attributes
    ----------
    frames : numpy.ndarray, shape (n_items, 4, 4)
        Each item's frame in the base frame (m), after the item.
    twist : numpy.ndarray, shape (6,)
        The joints' elastic twists, rad.
    deformation : numpy.ndarray, shape (n_items, 6)
        Each elastic item's ``[δ (m); φ (rad)]`` (zeros for the other items).
    torque : numpy.ndarray, shape (6,)
        The torque each joint carries, N·m (about its axis, from everything beyond it).
    residual : float
        Largest difference between a deflection and what its law gives at the returned frames (rad or m).
    iterations : int
    """

    frames: np.ndarray
    twist: np.ndarray
    deformation: np.ndarray
    torque: np.ndarray
    residual: float
    iterations: int


def _small_transform(d: np.ndarray) -> np.ndarray:
    """(4, 4) transform of a deformation ``[δ; φ]``: translation δ (m) and rotation by the vector φ (rad)."""
    T = np.eye(4)
    angle = float(np.linalg.norm(d[3:]))
    if angle > 0.0:
        T[:3, :3] = rotation(d[3:] / angle, angle)
    T[:3, 3] = d[:3]
    return T


def frames(items: tuple[Item, ...], angles: np.ndarray, deformation: np.ndarray | None = None) -> np.ndarray:
    """(n_items, 4, 4) frames after each item for joint ``angles`` (rad, actual) and elastic ``deformation`` (n_items, 6)."""
    out = np.empty((len(items), 4, 4))
    T = np.eye(4)
    for index, item in enumerate(items):
        if item.kind == "joint":
            R = np.eye(4)
            R[:3, :3] = rotation(item.axis, angles[item.joint])
            T = T @ R
        else:
            T = T @ item.offset
            if item.kind == "elastic" and deformation is not None:
                T = T @ _small_transform(deformation[index])
        out[index] = T
    return out


def _loads(robot: Robot, F: np.ndarray, mass: float, load_point: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every point load at the frames ``F``: the item it follows (L,), its place (L, 3) m and its force (L, 3) N."""
    g = robot.gravity * GRAVITY_DIRECTION
    where = [m.item for m in robot.masses]
    points = [F[m.item, :3, :3] @ m.point + F[m.item, :3, 3] for m in robot.masses]
    forces = [m.mass * g for m in robot.masses]
    if mass > 0.0:
        tool = F[robot.tool.item]
        where.append(robot.tool.item)
        points.append(tool[:3, :3] @ load_point + tool[:3, 3])
        forces.append(mass * g)
    c = robot.compensator
    p0 = F[c.item0, :3, :3] @ c.p0 + F[c.item0, :3, 3]
    p1 = F[c.item1, :3, :3] @ c.p1 + F[c.item1, :3, 3]
    s = float(np.linalg.norm(p0 - p1))
    pull = c.force(s) * (p0 - p1) / s
    where += [c.item1, c.item0]
    points += [p1, p0]
    forces += [pull, -pull]
    return np.array(where), np.array(points), np.array(forces)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (n, 3) arrays (numpy's general one costs more than the statics' whole arithmetic)."""
    return np.stack(
        [a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2], a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1
    )


def _carried(robot: Robot, F: np.ndarray, where: np.ndarray, points: np.ndarray, forces: np.ndarray):
    """Joint torques (6,) N·m and elastic items' wrenches (n_items, 6) in their own axes, from the loads beyond each."""
    compliant = np.array([index for index, item in enumerate(robot.items) if item.kind != "fixed"])
    beyond = (where[None, :] >= compliant[:, None]).astype(float)
    force = beyond @ forces
    moment = beyond @ _cross(points, forces) - _cross(F[compliant, :3, 3], force)
    R = F[compliant, :3, :3]
    torque = np.zeros(6)
    wrench = np.zeros((len(robot.items), 6))
    local_force = np.einsum("nji,nj->ni", R, force)
    local_moment = np.einsum("nji,nj->ni", R, moment)
    for row, index in enumerate(compliant):
        item = robot.items[index]
        if item.kind == "joint":
            # The axis is the same in the frames before and after the joint's rotation.
            torque[item.joint] = float(item.axis @ local_moment[row])
        else:
            wrench[index, :3], wrench[index, 3:] = local_force[row], local_moment[row]
    return torque, wrench


def solve(robot: Robot, q: np.ndarray, mass: float = 0.0, load_point: np.ndarray | None = None, play: np.ndarray | None = None) -> Equilibrium:
    """The equilibrium at commanded joints ``q`` (6,) rad, with ``mass`` (kg) hanging at ``load_point`` (flange frame, m).

    ``load_point`` defaults to the tool's; ``play`` (6,) rad is where each joint sits within its lost-motion band.

    Raises
    ------
    RuntimeError
        When the iteration has not settled after :data:`MAX_ITERATIONS` (loads far beyond the arm's).
    """
    load_point = robot.tool.load_point if load_point is None else load_point
    base = np.asarray(q, dtype=float) + robot.zero_offset + (0.0 if play is None else play)
    elastic = np.array([item.kind == "elastic" for item in robot.items])
    twist, deformation = np.zeros(6), np.zeros((len(robot.items), 6))
    for iteration in range(1, MAX_ITERATIONS + 1):
        F = frames(robot.items, base + twist, deformation)
        torque, wrench = _carried(robot, F, *_loads(robot, F, mass, load_point))
        new_twist = robot.joints.twist(torque)
        new_deformation = np.zeros_like(deformation)
        for index in np.flatnonzero(elastic):
            new_deformation[index] = robot.items[index].compliance @ wrench[index]
        residual = max(float(np.abs(new_twist - twist).max()), float(np.abs(new_deformation - deformation).max()))
        if residual < TOLERANCE:
            return Equilibrium(F, twist, deformation, torque, residual, iteration)
        twist, deformation = new_twist, new_deformation
    raise RuntimeError(f"the equilibrium did not settle in {MAX_ITERATIONS} iterations (last change {residual:.3g})")
