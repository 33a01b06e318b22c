"""Geometric errors of the independent generator: a DH error per joint, in this subpackage's own frames.

Each joint of the cell's robot gets a DH-style error (Hayati's β for the tilt a DH
α cannot express) applied after its nominal placement in a frame of this module's
own choosing: z along the joint's axis, x the joint frame's axis furthest from it
made square to it (not the calibration's frame, :func:`bayescal.kinematics.axes.axis_frame`).
The error transform is ``Rx(δα)·Ry(β)·Tx(δr)·Rz(δθ)·Tz(δd)``, composed from plain
rotation matrices.  The calibration can still be compared with it: the placement
error of a joint in any frame is the log of ``nominal⁻¹ · true``, exact whatever
the parameterisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.robot.kinematics import Robot
from bayescal.units import DEG, MM

__all__ = ["DH_SD", "GeometryErrors"]

DH_SD = {"theta": 0.07 * DEG, "d": 0.7 * MM, "r": 0.7 * MM, "alpha": 0.05 * DEG, "beta": 0.03 * DEG}
"""Sd of each drawn DH error.  ESTIMATES, not from a published calibration: the middle of the orders
assumed for a mastered heavy arm (offsets 0.05-0.1 deg, lengths 0.5-1 mm, twists about 0.05 deg); β, the tilt
about the common normal's companion axis, smaller than α (machined seats are squarer across than
along the link)."""

_ORDER = ("theta", "d", "r", "alpha", "beta")


def _turn(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.eye(3)
    out[i, i] = out[j, j] = c
    out[i, j], out[j, i] = -s, s
    return out


def _own_frame(axis: np.ndarray) -> np.ndarray:
    """``(3, 3)`` columns x, y, z: z the unit ``axis``, x the joint frame's unit vector least aligned with it, squared."""
    z = axis / np.linalg.norm(axis)
    seed = np.eye(3)[int(np.argmin(np.abs(z)))]
    x = seed - (seed @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(frozen=True)
class GeometryErrors:
    """Per joint ``(δθ, δd, δr, δα, β)`` in rad and m (``dh``, shape ``(nq, 5)``)."""

    dh: np.ndarray

    @classmethod
    def draw(cls, nq: int, rng: np.random.Generator, scale: float = 1.0) -> GeometryErrors:
        return cls(rng.normal(size=(nq, 5)) * np.array([DH_SD[k] for k in _ORDER]) * scale)

    def robot(self, robot: Robot) -> Robot:
        """A copy of ``robot`` with every joint's placement followed by its DH error."""
        model = robot.model.copy()
        data = model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))
        for j in range(1, model.njoints):
            frame = _own_frame(np.asarray(data.joints[j].S).reshape(-1)[3:])
            theta, d, r, alpha, beta = self.dh[j - 1]
            tilt = _turn(0, alpha) @ _turn(1, beta)
            rotation = tilt @ _turn(2, theta)
            translation = tilt @ np.array([r, 0.0, 0.0]) + rotation @ np.array([0.0, 0.0, d])
            error = pin.SE3(frame @ rotation @ frame.T, frame @ translation)
            model.jointPlacements[j] = model.jointPlacements[j] * error
        return robot.with_model(model)
