"""Kinematic errors of the digital twin: every joint placed a little off its nominal placement.

A real robot is not its URDF: its joint offsets, link lengths and axis twists are
off by fractions of a degree and of a millimetre.  :class:`KinematicErrors` holds,
per joint, the small rigid transform ``exp(δ)`` right-multiplied on its nominal
placement, with ``δ = (tx, ty, tz, rx, ry, rz)`` written in the frame where the
joint's axis is z (:func:`bayescal.kinematics.axes.axis_frame`): ``rz`` is the
joint offset, ``tz`` the DH d, ``tx, ty`` the DH r and its companion, ``rx, ry``
the DH α and β, the kinematic calibration's own parameters
(:mod:`bayescal.kinematics.model`).  :meth:`KinematicErrors.apply` returns the
erroneous robot; :func:`with_kinematic_errors` the cell the twin then simulates
(its loaded and unloaded equilibria and its markers all on the erroneous robot),
while the identification keeps the nominal cell.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.kinematics.axes import corrected_robot
from bayescal.robot.kinematics import Robot
from bayescal.units import DEG, MM

__all__ = ["COMPONENTS", "ERROR_SD", "KINEMATIC_ERRORS_STREAM", "KinematicErrors", "with_kinematic_errors"]

COMPONENTS = ("tx", "ty", "tz", "rx", "ry", "rz")
"""The six components of a joint's placement error, in the frame where its axis is z."""

ERROR_SD = {"length": 0.5 * MM, "twist": 0.05 * DEG, "offset": 0.05 * DEG}
"""Sd (SI) of each component of a drawn error: translations (``length``), the rotations across the axis
(``twist``) and about it (``offset``).  ESTIMATES for a heavy arm of 1-3 m links after its maker's
mastering, not taken from a published calibration of this robot: joint offsets of 0.05-0.1 deg, lengths
of 0.5-1 mm and twists of about 0.05 deg are the order assumed, and the sds sit at the low end; the independent
generator of measured points draws wider ones for a humanoid (:mod:`bayescal.twin.independent.points`)."""

KINEMATIC_ERRORS_STREAM = 1
"""``bayescal simulate`` draws the errors from ``default_rng([seed, KINEMATIC_ERRORS_STREAM])``, apart from the noise's stream."""

_SD_OF_COMPONENT = {"tx": "length", "ty": "length", "tz": "length", "rx": "twist", "ry": "twist", "rz": "offset"}


@dataclass(frozen=True)
class KinematicErrors:
    """Each chain joint's placement error.

    Attributes
    ----------
    deltas : numpy.ndarray
        ``(nq, 6)`` per joint ``(tx, ty, tz, rx, ry, rz)`` in m and rad, in the frame where its axis is z.
    joint_names : tuple of str
    """

    deltas: np.ndarray
    joint_names: tuple[str, ...]

    @classmethod
    def draw(cls, robot: Robot, rng: np.random.Generator, *, scale: float = 1.0) -> KinematicErrors:
        """Errors of every joint of ``robot``, each component normal with sd ``scale`` times :data:`ERROR_SD`'s."""
        if not (np.isfinite(scale) and scale >= 0):
            raise ValueError(f"scale must be a finite number >= 0, got {scale}")
        sd = np.array([ERROR_SD[_SD_OF_COMPONENT[c]] for c in COMPONENTS]) * scale
        return cls(deltas=rng.normal(size=(robot.nq, 6)) * sd, joint_names=robot.joint_names)

    def apply(self, robot: Robot) -> Robot:
        """A copy of ``robot`` with every joint's placement times its error (in the joint's axis frame)."""
        return corrected_robot(robot, self.deltas)

    def summary(self) -> pd.DataFrame:
        """One row per joint: each component in mm or deg."""
        scale = np.array([MM if c[0] == "t" else DEG for c in COMPONENTS])
        units = [f"{c}_{'mm' if c[0] == 't' else 'deg'}" for c in COMPONENTS]
        frame = pd.DataFrame(self.deltas / scale, columns=units, index=pd.Index(self.joint_names, name="joint"))
        return frame

    def named(self) -> dict[str, float]:
        """Each component as the kinematic calibration names it (``A2.rz``), SI."""
        return {f"{name}.{c}": float(v) for name, row in zip(self.joint_names, self.deltas) for c, v in zip(COMPONENTS, row)}


def with_kinematic_errors(cell: Cell, errors: KinematicErrors) -> Cell:
    """``cell`` with its robot carrying ``errors``: what the twin simulates when the robot is not its URDF."""
    return dataclasses.replace(cell, robot=errors.apply(cell.robot))
