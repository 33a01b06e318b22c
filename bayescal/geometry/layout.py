"""Where the compensator's markers are at a joint angle: the one marker-layout model (SI, tracker frame).

The lever marker P1 turns with joint 2 about the axis through p2::

    P1(q2) = p2 + L·[cos α, sin α],   α = phi + sense·(1 + e)·q2

(eq 10; ``sense`` -1 when the lever turns clockwise in the tracker's (x, y) as on
Table I; ``e`` a gain error of the angle reading, 0 for the paper's model).  Each
cylinder marker sits on the cylinder that runs from its pivot through P1, at
distance ``R`` from the pivot and angle ``δ`` from the cylinder's direction::

    P0k(q2) = pivot + R·[cos β, sin β],   β = atan2(P1 - pivot) + δ + turn

with ``pivot = p0`` and ``turn = 0`` for markers rigid on the cylinder.  The
extensions the geometry critique and the twin's planted effects need are
arguments of the same functions: a gain ``e`` on q2, a pivot that moves, a turn of
the markers about the cylinder's axis, a radius that varies.  Every argument
broadcasts, so one call places the markers for many joint angles and many
parameter sets at once (the posterior's ``(..., n)`` arrays, the critique's
Jacobian batches).  :class:`~bayescal.geometry.arcs.MarkerLayout`, the geometry
posterior, the geometry critique and the twin's geometry simulator all place the
markers with these functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["lever_angle", "lever_points", "cylinder_direction", "cylinder_points", "marker_offset", "circular_mean"]


def lever_angle(phi: ArrayLike, sense: int, q2: ArrayLike, joint_scale: ArrayLike = 0.0) -> np.ndarray:
    """The lever's angle α (rad) in the tracker's (x, y) at joint angles ``q2`` (rad).

    Parameters
    ----------
    phi
        Lever angle at q2 = 0 (rad).
    sense
        +1 when the lever turns counter-clockwise in the tracker's (x, y) as q2 increases, -1 otherwise.
    q2
        Joint angles (rad), broadcast against ``phi``.
    joint_scale
        Relative gain error ``e`` of the angle reading (the lever turns by ``(1 + e) q2``).
    """
    return phi + sense * (1.0 + joint_scale) * q2


def lever_points(p2_x: ArrayLike, p2_y: ArrayLike, L: ArrayLike, angle: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """x and y (m) of P1 at the lever angles ``angle`` (rad, :func:`lever_angle`), about the centre ``p2``."""
    return p2_x + L * np.cos(angle), p2_y + L * np.sin(angle)


def cylinder_direction(lever_x: ArrayLike, lever_y: ArrayLike, pivot_x: ArrayLike, pivot_y: ArrayLike) -> np.ndarray:
    """Direction (rad, from the tracker's X) of the cylinder from its pivot towards P1."""
    return np.arctan2(lever_y - pivot_y, lever_x - pivot_x)


def cylinder_points(
    pivot_x: ArrayLike,
    pivot_y: ArrayLike,
    direction: ArrayLike,
    radius: ArrayLike,
    offset: ArrayLike,
    turn: ArrayLike = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x and y (m) of a cylinder marker, and its angle β (rad) about the pivot.

    Parameters
    ----------
    pivot_x, pivot_y
        The cylinder's pivot (p0, or where an extension moved it), m.
    direction
        The cylinder's direction (:func:`cylinder_direction`), rad.
    radius
        The marker's distance from the pivot, m.
    offset
        The marker's angle δ from the cylinder's direction, rad.
    turn
        An extra turn of the marker about the pivot (rad), 0 for markers rigid on the cylinder.
    """
    angle = direction + offset + turn
    return pivot_x + radius * np.cos(angle), pivot_y + radius * np.sin(angle), angle


def marker_offset(x: ArrayLike, y: ArrayLike, pivot_x: ArrayLike, pivot_y: ArrayLike, direction: ArrayLike) -> np.ndarray:
    """A cylinder marker's angle about the pivot from the cylinder's direction, read from its position.

    The inverse of :func:`cylinder_points` for ``offset + turn``: rad, not wrapped (the
    difference of two angles in (-π, π]).

    Parameters
    ----------
    x, y
        The marker's position (m), broadcast against the rest.
    pivot_x, pivot_y
        The cylinder's pivot (m).
    direction
        The cylinder's direction (:func:`cylinder_direction`) at the marker's joint angle, rad.
    """
    return np.arctan2(y - pivot_y, x - pivot_x) - direction


def circular_mean(angles: ArrayLike) -> float:
    """The mean direction (rad, in (-π, π]) of ``angles`` (rad): a marker's offset over its points."""
    return float(np.angle(np.mean(np.exp(1j * np.asarray(angles)))))
