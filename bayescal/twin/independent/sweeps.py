"""Joint sweeps with the errors a circle model of the arcs leaves out, in this generator's own forms.

Written before, and apart from, the sweep critique (:mod:`bayescal.critique.sweeps`),
so that it can be measured on data it was not built from.  A sweep moves one
joint from a home pose; the reflectors' true positions come from the robot's
forward kinematics (Pinocchio) at the joint's *true* angle, which differs from
the commanded one the file records, then the tracker reads them with its own
anisotropic noise (:class:`~bayescal.twin.independent.noise.TrackerReadout`).

The effects, each with a default size (``magnitude`` multiplies it):

* ``gear_ratio``: the joint turns by ``(1 + ε)`` times the commanded change from
  home, ε = 5e-4 (ESTIMATE: a reducer's ratio known to about a thousandth).
* ``transmission``: a cyclic transmission error, two harmonics of the joint
  angle with random phases, ``A (sin(2q + ψ1) + 0.6 sin(5q + ψ2))``, A = 0.005°
  (ESTIMATE: 18 arcsec, within the arc-minute of an industrial reducer's
  transmission error).
* ``wobble``: the axis tilts as the joint turns, about a random direction
  across it, by ``β`` per radian of turn from home: the distal links turn
  about the joint's origin by ``β (q - home)`` about that direction, β = 1 mrad/rad
  (ESTIMATE: a bearing whose axis moves by a fraction of a mrad over a sweep).
* ``range_offset``: every distance the tracker reads is off by ``d0`` = 30 μm
  (ESTIMATE: a reflector whose offset from its nest's centre is mis-set).
* ``tracker_scale``: every distance read times ``(1 + s)``, s = 20e-6 (the
  AT901's distance error at 4 m in ppm, ESTIMATE): a scale about the tracker,
  which maps every circle onto a circle about the same axis direction.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pinocchio as pin
from scipy.spatial.transform import Rotation

from bayescal.cell.config import Cell
from bayescal.twin.independent.noise import TrackerReadout
from bayescal.units import DEG, MM, UM

__all__ = ["SWEEP_EFFECTS", "SweepEffect", "independent_sweeps"]

SWEEP_EFFECTS = {
    "gear_ratio": 5e-4,
    "transmission": 0.005 * DEG,
    "wobble": 1e-3,
    "range_offset": 30 * UM,
    "tracker_scale": 20e-6,
}
"""Default size of each effect: relative, rad, rad per rad, m, relative."""


@dataclass(frozen=True)
class SweepEffect:
    """One planted effect: its name, its size (SI, ``SWEEP_EFFECTS``' units) and the random phases and direction it needs."""

    name: str
    size: float
    phases: tuple[float, float] = (0.0, 0.0)
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)

    @classmethod
    def draw(cls, name: str, magnitude: float, rng: np.random.Generator) -> SweepEffect:
        """``name`` at ``magnitude`` times its default size, with random phases and tilt direction."""
        if name not in SWEEP_EFFECTS:
            raise ValueError(f"unknown sweep effect {name!r}; expected one of {', '.join(SWEEP_EFFECTS)}")
        phases = tuple(float(p) for p in rng.uniform(0, 2 * np.pi, 2))
        direction = tuple(float(d) for d in rng.normal(size=3))
        return cls(name, magnitude * SWEEP_EFFECTS[name], phases, direction)

    def true_angle(self, q: float, home: float) -> float:
        """The joint's true angle (rad) when the controller reports ``q``."""
        if self.name == "gear_ratio":
            return home + (1.0 + self.size) * (q - home)
        if self.name == "transmission":
            return q + self.size * (np.sin(2 * q + self.phases[0]) + 0.6 * np.sin(5 * q + self.phases[1]))
        return q


def _axis_line(cell: Cell, q: np.ndarray, joint: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit axis and origin (base frame) of ``joint`` (0-based) at ``q``, from Pinocchio's world Jacobian."""
    model = cell.robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    column = pin.getJointJacobian(model, data, joint + 1, pin.ReferenceFrame.WORLD)[3:, model.joints[joint + 1].idx_v]
    return column / np.linalg.norm(column), data.oMi[joint + 1].translation.copy()


def _read(points: np.ndarray, tracker, readout: TrackerReadout, effect: SweepEffect | None, rng) -> np.ndarray:
    """Tracker-frame readings of base-frame ``points``: distance effects, then the tracker's noise, then its frame."""
    offset = points - tracker.position
    distance = np.linalg.norm(offset, axis=1, keepdims=True)
    if effect is not None and effect.name == "range_offset":
        points = points + effect.size * offset / distance
    if effect is not None and effect.name == "tracker_scale":
        points = tracker.position + (1.0 + effect.size) * offset
    return tracker.to_tracker(readout.read(points, rng))


def independent_sweeps(
    cell: Cell,
    tracker,
    rng: np.random.Generator,
    *,
    home_deg: Sequence[float],
    effect: SweepEffect | None = None,
    joints: Sequence[int] = (0, 1),
    span_deg: float = 50.0,
    angles: int = 8,
    reflectors_mm: Sequence[Sequence[float]] = ((120.0, 60.0, 80.0), (-100.0, 110.0, 30.0), (20.0, -140.0, 150.0)),
) -> pd.DataFrame:
    """Sweep readings as a sweep-file table (``joint`` 1-based, ``q*_deg`` commanded, ``marker``, ``*_mm`` tracker frame).

    Parameters
    ----------
    cell
        The robot and the tracker's noise scale.
    tracker
        Where the tracker stands and how it is turned (:class:`~bayescal.twin.sweeps.TrackerPlacement`);
        its ``position`` is also where the noise is measured from.
    rng
        Noise, and the angles' jitter: each sweep's angles are evenly spaced over ``span_deg``, each moved by
        up to a tenth of a step, as a hand-taught sweep is.
    effect
        The planted effect, or None.
    """
    robot = cell.robot
    home = np.asarray(home_deg, dtype=float) * DEG
    readout = TrackerReadout(type(cell.tracker)(tracker.position, cell.tracker.U0, cell.tracker.U1, cell.tracker.factor))
    points = np.asarray(reflectors_mm, dtype=float) * MM
    step = span_deg / (angles - 1)
    rows = []
    for j in joints:
        axis, origin = _axis_line(cell, home, j)
        across = np.cross(axis, np.asarray(effect.direction if effect else (1.0, 0.0, 0.0)))
        across /= np.linalg.norm(across)
        commanded = home[j] + (np.linspace(-span_deg / 2, span_deg / 2, angles) + rng.uniform(-0.1, 0.1, angles) * step) * DEG
        for q_j in commanded:
            q = home.copy()
            q[j] = effect.true_angle(q_j, home[j]) if effect else q_j
            base = robot.point_position(q, points)
            if effect is not None and effect.name == "wobble":
                tilt = Rotation.from_rotvec(effect.size * (q_j - home[j]) * across).as_matrix()
                base = (base - origin) @ tilt.T + origin
            read = _read(base, tracker, readout, effect, rng)
            reported = home.copy()
            reported[j] = q_j
            for k, xyz in enumerate(read):
                rows.append({"joint": j + 1, **{f"q{i + 1}_deg": reported[i] / DEG for i in range(robot.nq)},
                             "marker": f"T{k + 1}", "x_mm": xyz[0] / MM, "y_mm": xyz[1] / MM, "z_mm": xyz[2] / MM})
    return pd.DataFrame(rows)
