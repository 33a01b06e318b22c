"""Which of a 6-axis arm's solutions a target means: KUKA's status and turn, ABB's ``confdata``.

One geometric reading of the arm serves both controllers (sources in docs/controllers.md):

* *overhead*: the wrist point (the origin of joint 5's frame, where the axes of
  joints 4, 5 and 6 meet) lies behind axis 1, at negative x of joint 1's frame;
* *elbow front*: the wrist point lies on the front side of the line from axis 2
  to axis 3 (the side ``(O3 - O2) × m`` points to, ``m = x₁ × up``): on the
  KR-270 it is KUKA's "A3 ≥ φ", φ the angle at which the wrist point is on that line;
* *wrist flipped*: the angle of joint 5 is negative (KUKA: ``A5 ≤ 0``; ABB: ``A5 < 0``).

KUKA's status ``S``: bit 0 overhead, bit 1 elbow front, bit 2 ``A5 ≤ 0`` (bits 3
and up are the controller's own and pass unchanged); the turn ``T``: bit ``j``
set when axis ``j + 1`` is negative.  ABB's ``cfx``: 4 × overhead + 2 × (elbow
not front, "behind the lower arm") + (``A5 < 0``), and ``cf1``, ``cf4``, ``cf6`` the
quadrants ``floor(angle / 90°)`` of axes 1, 4 and 6.
"""

from __future__ import annotations

import numpy as np

from bayescal.errors import InputError
from bayescal.robot.batched import BatchedChain
from bayescal.robot.kinematics import Robot

__all__ = ["arm_geometry", "kuka_status", "kuka_turn", "abb_cfx", "abb_quadrants", "check_six_axis", "turned_to"]


def check_six_axis(robot: Robot, source: str) -> None:
    """Refuse a robot the configuration bits do not describe: six revolute joints in a chain."""
    if robot.nq != 6 or robot.prismatic.any():
        raise InputError(
            f"a controller program's configuration (status/turn, confdata) is that of a 6-axis arm; the cell's robot has "
            f"{robot.nq} joints{' with a prismatic one' if robot.prismatic.any() else ''}",
            source=source,
        )


def arm_geometry(robot: Robot, q: np.ndarray) -> np.ndarray:
    """``(N, 3)`` bool: overhead, elbow front, ``A5 ≤ 0``, of ``(N, 6)`` joints (rad)."""
    chain = BatchedChain.of(robot)
    poses = chain.poses(q)
    origins, axes = poses.origins, poses.axes
    wrist = origins[:, 4]
    up = -chain.gravity / np.linalg.norm(chain.gravity)
    # Joint 1's x axis: its frame's x turned about its axis by q1 (Rodrigues), placed as the model places it.
    x0 = chain.rotations[0][:, 0]
    axis = axes[:, 0]
    angle = q[:, 0:1]
    x1 = x0 * np.cos(angle) + np.cross(axis, x0) * np.sin(angle) + axis * (axis @ x0)[:, None] * (1 - np.cos(angle))
    overhead = np.einsum("ni,ni->n", wrist - origins[:, 0], x1) < 0
    m = np.cross(x1, up)
    front = np.einsum("ni,ni->n", wrist - origins[:, 1], np.cross(origins[:, 2] - origins[:, 1], m)) > 0
    return np.column_stack([overhead, front, q[:, 4] <= 0])


def kuka_status(robot: Robot, q: np.ndarray) -> np.ndarray:
    """``(N,)`` KUKA status bits 0-2 of ``(N, 6)`` joints (rad)."""
    bits = arm_geometry(robot, q)
    return bits[:, 0] * 1 + bits[:, 1] * 2 + bits[:, 2] * 4


def kuka_turn(q: np.ndarray) -> np.ndarray:
    """``(N,)`` KUKA turn: bit ``j`` set when axis ``j + 1`` is negative."""
    return ((np.asarray(q) < 0) * (1 << np.arange(q.shape[1]))).sum(axis=1)


def abb_cfx(robot: Robot, q: np.ndarray) -> np.ndarray:
    """``(N,)`` ABB ``cfx`` of ``(N, 6)`` joints (rad)."""
    bits = arm_geometry(robot, q)
    return bits[:, 0] * 4 + (~bits[:, 1]) * 2 + (q[:, 4] < 0) * 1


def abb_quadrants(q: np.ndarray) -> np.ndarray:
    """``(N, 3)`` ABB ``cf1, cf4, cf6``: the quadrants ``floor(angle / 90°)`` of axes 1, 4, 6."""
    return np.floor(np.asarray(q)[:, [0, 3, 5]] / (np.pi / 2)).astype(int)


def turned_to(robot: Robot, q: np.ndarray, wanted) -> np.ndarray:
    """``q`` with each revolute joint turned by whole turns (within its limits) so that ``wanted(angle, joint)``
    holds where a turn can make it; ``wanted`` takes ``(N,)`` angles and a joint, returns ``(N,)`` bool."""
    out = np.array(q, dtype=float)
    for j in range(robot.nq):
        for turns in (1, -1, 2, -2):
            shifted = out[:, j] + turns * 2 * np.pi
            better = ~wanted(out[:, j], j) & wanted(shifted, j) & (robot.lower[j] <= shifted) & (shifted <= robot.upper[j])
            out[better, j] = shifted[better]
    return out
