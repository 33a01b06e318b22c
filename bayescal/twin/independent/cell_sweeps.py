"""Joint sweeps with a real cell's error budget, for checking the registration on data it was not built from.

Written apart from the axis fit (:mod:`bayescal.registration.axes`): the reflectors
are moved by this module's own rotation code (Rodrigues' formula about each
joint's true axis line, taken from the URDF at the home pose), never by the fit's
circle model, and read by a tracker whose noise is anisotropic
(:class:`~bayescal.twin.independent.noise.TrackerReadout`).  The errors a real
cell adds, each drawn per file:

* the tracker's noise ``noise_factor`` times the cell's law (3-10 by default:
  real sweeps scatter 2.4-6.7 times the KR-270 cell's law, ``docs/registration.md``);
* the reflector's seating: each reading's reflector off its nest's centre by
  :data:`SEATING_SD` in every coordinate (re-seated between readings);
* the joint's wobble: at each angle the distal links tilted about the joint's
  origin by :data:`WOBBLE_SD` about a random direction across the axis;
* the joint's transmission error: ``A (sin(2q + ψ1) + 0.6 sin(5q + ψ2))``, ``A =``
  :data:`TRANSMISSION`, plus :data:`POSITIONING_SD` at each angle;
* a reflector dropped at some angles (a broken beam): each reading missing with
  probability :data:`DROP`, each reflector kept at four angles at least.

The truth is what the registration estimates: each swept joint's axis line at
the home pose and the URDF base frame, both in the tracker frame.
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

__all__ = ["CellSweeps", "cell_sweeps", "swap_labels", "SEATING_SD", "WOBBLE_SD", "TRANSMISSION", "POSITIONING_SD", "DROP"]

SEATING_SD = 10 * UM
"""Reflector off its nest's centre when re-seated, per coordinate (ESTIMATE: magnetic nests repeat to 5-15 μm)."""
WOBBLE_SD = 0.05e-3
"""Tilt of the joint's axis at each angle, rad (ESTIMATE: a bearing's run-out of tens of μrad)."""
TRANSMISSION = 0.005 * DEG
"""Amplitude of the cyclic transmission error, rad (ESTIMATE: 18 arcsec, within an industrial reducer's arc-minute)."""
POSITIONING_SD = 0.002 * DEG
"""The joint's repeatability at each angle, rad (ESTIMATE: 7 arcsec, a few μm at a metre)."""
DROP = 0.1
"""Probability that a reading is missing (ESTIMATE: the beam broken by the arm at one angle in ten)."""
_MIN_KEPT = 4
"""Fewest angles at which each reflector is kept."""


@dataclass(frozen=True)
class CellSweeps:
    """One generated sweep file and its truth (tracker frame, SI units).

    Attributes
    ----------
    table
        The sweep file's rows: ``joint`` (1-based), ``q*_deg`` (commanded), ``marker``, ``x_mm, y_mm, z_mm``.
    axes
        0-based joint -> (unit direction, point nearest the tracker origin, m) of its true axis at home.
    base
        ``(R, t)``: the URDF base frame in the tracker frame, ``p_tracker = R p_base + t``.
    noise_factor
        The tracker's noise over the cell's law in this file.
    """

    table: pd.DataFrame
    axes: dict[int, tuple[np.ndarray, np.ndarray]]
    base: tuple[np.ndarray, np.ndarray]
    noise_factor: float


def _rodrigues(points: np.ndarray, axis: np.ndarray, origin: np.ndarray, angle: float) -> np.ndarray:
    """(k, 3) points turned by ``angle`` (rad) about the line through ``origin`` along unit ``axis``."""
    v = points - origin
    cos, sin = np.cos(angle), np.sin(angle)
    return origin + v * cos + np.cross(axis, v) * sin + np.outer(v @ axis, axis) * (1 - cos)


def _home_lines(cell: Cell, home: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray]], pin.SE3]:
    """Every joint's (unit axis, origin) in the base frame at ``home`` and the flange's placement, from the URDF."""
    model = cell.robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, home)
    pin.updateFramePlacements(model, data)
    lines = []
    for j in range(1, model.njoints):
        column = pin.getJointJacobian(model, data, j, pin.ReferenceFrame.WORLD)[3:, model.joints[j].idx_v]
        lines.append((column / np.linalg.norm(column), data.oMi[j].translation.copy()))
    return lines, data.oMf[model.getFrameId(cell.robot.flange)]


def _placement(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The tracker: 2-5 m from the base at a random bearing, 0-1.5 m high, turned uniformly; (rotation, position) in base."""
    bearing, distance = rng.uniform(0, 2 * np.pi), rng.uniform(2.0, 5.0)
    position = np.array([distance * np.cos(bearing), distance * np.sin(bearing), rng.uniform(0.0, 1.5)])
    return Rotation.random(random_state=rng).as_matrix(), position


def cell_sweeps(
    cell: Cell,
    rng: np.random.Generator,
    *,
    home_deg: Sequence[float],
    joints: Sequence[int] = (0, 1),
    noise_factor: float | None = None,
    span_deg: float = 50.0,
    angles: int = 7,
    loose: float = 1.0,
) -> CellSweeps:
    """A sweep file of ``joints`` (0-based) with the cell's error budget, and its truth.

    Parameters
    ----------
    cell
        The robot (its URDF) and the tracker's noise law.
    rng
        Every random draw.
    home_deg
        (nq,) the home pose, deg.
    noise_factor
        The tracker's noise over the cell's law; drawn uniformly in 3-10 when None.
    span_deg, angles
        Each sweep's angles: evenly over ``home ± span_deg / 2``, each moved by up to a tenth of a step.
    loose
        The first reflector's seating error and noise times this (a loose nest: large but honest scatter).
    """
    home = np.asarray(home_deg, dtype=float) * DEG
    factor = float(rng.uniform(3.0, 10.0)) if noise_factor is None else float(noise_factor)
    rotation, position = _placement(rng)
    tracker = type(cell.tracker)(position, cell.tracker.U0, cell.tracker.U1, cell.tracker.factor * factor)
    readout = TrackerReadout(tracker)
    lines, flange = _home_lines(cell, home)
    reflectors = _reflectors(flange, rng)
    scale, step = np.array([loose, 1.0, 1.0]), span_deg / (angles - 1)
    rows = []
    for j in joints:
        axis, origin = lines[j]
        phases = rng.uniform(0, 2 * np.pi, 2)
        commanded = home[j] + (np.linspace(-span_deg / 2, span_deg / 2, angles) + rng.uniform(-0.1, 0.1, angles) * step) * DEG
        kept = rng.random((angles, 3)) >= DROP
        for k in range(3):
            missing = np.flatnonzero(~kept[:, k])
            kept[missing[: max(0, _MIN_KEPT - int(kept[:, k].sum()))], k] = True
        for i, q_j in enumerate(commanded):
            error = TRANSMISSION * (np.sin(2 * q_j + phases[0]) + 0.6 * np.sin(5 * q_j + phases[1])) + rng.normal() * POSITIONING_SD
            moved = _rodrigues(reflectors, axis, origin, q_j - home[j] + error)
            across = np.cross(axis, rng.normal(size=3))
            moved = _rodrigues(moved, across / np.linalg.norm(across), origin, rng.normal() * WOBBLE_SD)
            moved += rng.normal(size=(3, 3)) * SEATING_SD * scale[:, None]
            noisy = moved + (readout.read(moved, rng) - moved) * scale[:, None]
            read = (noisy - position) @ rotation
            reported = home.copy()
            reported[j] = q_j
            for k in np.flatnonzero(kept[i]):
                rows.append({"joint": j + 1, **{f"q{m + 1}_deg": reported[m] / DEG for m in range(home.size)},
                             "marker": f"S{k + 1}", "x_mm": read[k, 0] / MM, "y_mm": read[k, 1] / MM, "z_mm": read[k, 2] / MM})
    truth = {j: _axis_in_tracker(*lines[j], rotation, position) for j in joints}
    return CellSweeps(pd.DataFrame(rows), truth, (rotation.T, -rotation.T @ position), factor)


def _reflectors(flange, rng: np.random.Generator) -> np.ndarray:
    """(3, 3) three reflectors in base, m: 100-250 mm off the flange's axis at random azimuths, 30-150 mm out along it."""
    azimuth = rng.uniform(0, 2 * np.pi) + np.array([0.0, 2.1, 4.2]) + rng.uniform(-0.3, 0.3, 3)
    offsets = np.column_stack([rng.uniform(0.10, 0.25, 3) * np.cos(azimuth), rng.uniform(0.10, 0.25, 3) * np.sin(azimuth),
                               rng.uniform(0.03, 0.15, 3)])
    return flange.translation + offsets @ flange.rotation.T


def _axis_in_tracker(axis: np.ndarray, origin: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A joint's base-frame axis line as the tracker sees it: (direction, the line's point nearest the tracker), m."""
    a, p = rotation.T @ axis, (origin - position) @ rotation
    return a, p - (p @ a) * a


def swap_labels(table: pd.DataFrame, joint: int, rng: np.random.Generator) -> pd.DataFrame:
    """``table`` with two reflectors' names swapped at one angle of ``joint``'s sweep (0-based) where both were read."""
    rows = table[table["joint"] == joint + 1]
    column = f"q{joint + 1}_deg"
    both = [q for q, group in rows.groupby(column) if group["marker"].nunique() >= 2]
    q = both[rng.integers(len(both))]
    group = rows[rows[column] == q]
    first, second = rng.choice(group.index.to_numpy(), 2, replace=False)
    out = table.copy()
    out.loc[[first, second], "marker"] = [table.at[second, "marker"], table.at[first, "marker"]]
    return out
