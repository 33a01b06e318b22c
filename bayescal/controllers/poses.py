"""Frames as controllers write them: KUKA's X, Y, Z, A, B, C and ABB's position and quaternion.

The conventions (sources in docs/controllers.md):

* KUKA KRL ``FRAME``/``POS``/``E6POS``: ``X, Y, Z`` in mm; ``A, B, C`` in deg, the
  rotation ``R = Rz(A) Ry(B) Rx(C)`` (turn about Z by A, then about the new Y by B,
  then about the new X by C);
* ABB RAPID ``pose`` (``robtarget``'s ``trans, rot``, ``tooldata``'s ``tframe``,
  ``wobjdata``'s ``uframe`` and ``oframe``): ``[x, y, z]`` in mm and the unit
  quaternion ``[q1, q2, q3, q4] = [w, x, y, z]``, scalar first.

Inside, a frame is a rotation ``(…, 3, 3)`` and an origin ``(…, 3)`` in m, both in
the frame it is given in; stacks of ``N`` frames are arrays with a leading axis.
"""

from __future__ import annotations

import numpy as np

from bayescal.units import DEG

__all__ = ["kuka_rotation", "kuka_angles", "quaternion_rotation", "rotation_quaternion", "compose", "inverse"]


def kuka_rotation(abc_deg: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` rotations ``Rz(A) Ry(B) Rx(C)`` of ``(N, 3)`` angles ``A, B, C`` in deg."""
    a, b, c = (np.asarray(abc_deg, dtype=float) * DEG).T
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    return np.stack(
        [
            np.stack([ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc], axis=-1),
            np.stack([sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc], axis=-1),
            np.stack([-sb, cb * sc, cb * cc], axis=-1),
        ],
        axis=-2,
    )


def kuka_angles(rotation: np.ndarray) -> np.ndarray:
    """``(N, 3)`` angles ``A, B, C`` (deg, ``A`` and ``C`` in (-180, 180], ``B`` in [-90, 90]) of ``(N, 3, 3)`` rotations."""
    r = np.asarray(rotation, dtype=float)
    b = np.arctan2(-r[:, 2, 0], np.hypot(r[:, 0, 0], r[:, 1, 0]))
    a = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    c = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    return np.column_stack([a, b, c]) / DEG


def quaternion_rotation(quaternion: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` rotations of ``(N, 4)`` unit quaternions ``[w, x, y, z]``."""
    w, x, y, z = np.asarray(quaternion, dtype=float).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )


def rotation_quaternion(rotation: np.ndarray) -> np.ndarray:
    """``(N, 4)`` unit quaternions ``[w, x, y, z]`` of ``(N, 3, 3)`` rotations, ``w >= 0``.

    Shepperd's method: from the largest of ``w², x², y², z²``, so that no division is by a small number.
    """
    r = np.asarray(rotation, dtype=float)
    trace = np.einsum("nii->n", r)
    squares = np.column_stack([1 + trace, 1 + 2 * r[:, 0, 0] - trace, 1 + 2 * r[:, 1, 1] - trace, 1 + 2 * r[:, 2, 2] - trace]) / 4
    largest = np.argmax(squares, axis=1)
    big = np.sqrt(np.take_along_axis(squares, largest[:, None], axis=1))[:, 0]
    # Each product of two components is an off-diagonal sum or difference: 4 w x = R21 - R12, 4 x y = R10 + R01, ...
    products = {
        (0, 1): r[:, 2, 1] - r[:, 1, 2], (0, 2): r[:, 0, 2] - r[:, 2, 0], (0, 3): r[:, 1, 0] - r[:, 0, 1],
        (1, 2): r[:, 1, 0] + r[:, 0, 1], (1, 3): r[:, 0, 2] + r[:, 2, 0], (2, 3): r[:, 2, 1] + r[:, 1, 2],
    }
    out = np.empty((r.shape[0], 4))
    for k in range(4):
        pick = largest == k
        out[pick, k] = big[pick]
        for other in range(4):
            if other != k:
                out[pick, other] = products[tuple(sorted((k, other)))][pick] / (4 * big[pick])
    return out * np.where(out[:, :1] < 0, -1.0, 1.0)


def compose(first: tuple[np.ndarray, np.ndarray], second: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The frame ``second`` given in ``first``, expressed where ``first`` is: ``(R1 R2, R1 t2 + t1)``; stacks broadcast."""
    r1, t1 = first
    r2, t2 = second
    return r1 @ r2, np.einsum("...ij,...j->...i", r1, t2) + t1


def inverse(frame: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``(Rᵀ, -Rᵀ t)``: the frame in which ``frame``'s parent is given."""
    rotation, origin = frame
    transposed = np.swapaxes(rotation, -1, -2)
    return transposed, -np.einsum("...ij,...j->...i", transposed, origin)
