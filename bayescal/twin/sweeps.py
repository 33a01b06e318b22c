"""Simulated joint sweeps: one joint at a time moved from a home pose, read by a tracker placed and turned at random.

The reflectors ride on the flange, so they turn about every joint's axis; the
positions come from the robot's forward kinematics (Pinocchio), not from the
circle model the registration fits, and the noise is the cell's
distance-dependent tracker noise about the tracker's own position.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from bayescal.cell.config import Cell
from bayescal.units import DEG, MM

__all__ = ["TrackerPlacement", "random_placement", "simulate_sweeps"]


@dataclass(frozen=True)
class TrackerPlacement:
    """The tracker frame in the robot's base frame: ``p_base = rotation @ p_tracker + position``."""

    rotation: np.ndarray
    position: np.ndarray

    def to_tracker(self, points: np.ndarray) -> np.ndarray:
        """(k, 3) base-frame points, m -> tracker frame, m."""
        return (np.asarray(points) - self.position) @ self.rotation


def random_placement(rng: np.random.Generator, distance: tuple[float, float] = (2.0, 5.0)) -> TrackerPlacement:
    """A tracker at a random bearing and ``distance`` (m) from the base, 0-1.5 m high, turned uniformly at random."""
    bearing = rng.uniform(0, 2 * np.pi)
    r = rng.uniform(*distance)
    position = np.array([r * np.cos(bearing), r * np.sin(bearing), rng.uniform(0.0, 1.5)])
    return TrackerPlacement(Rotation.random(random_state=rng).as_matrix(), position)


def simulate_sweeps(
    cell: Cell,
    placement: TrackerPlacement,
    rng: np.random.Generator,
    *,
    home_deg: Sequence[float],
    joints: Sequence[int] = (0, 1),
    span_deg: float = 40.0,
    angles: int = 9,
    reflectors_mm: Sequence[Sequence[float]] = ((150.0, 0.0, 50.0), (-80.0, 130.0, 50.0), (0.0, -150.0, 120.0)),
) -> pd.DataFrame:
    """Readings of sweeps of ``joints`` (0-based) as a sweep-file table (``joint`` 1-based, ``q*_deg``, ``marker``, ``*_mm``).

    Each joint moves through ``angles`` angles over ``home ± span_deg / 2``, the others stay at ``home_deg``.
    """
    robot = cell.robot
    home = np.asarray(home_deg, dtype=float) * DEG
    noise = cell.tracker
    points = np.asarray(reflectors_mm, dtype=float) * MM
    rows = []
    for j in joints:
        for angle in np.linspace(-span_deg / 2, span_deg / 2, angles) * DEG:
            q = home.copy()
            q[j] += angle
            base = robot.point_position(q, points)
            sigma = noise.factor * (noise.U0 + noise.U1 * np.linalg.norm(base - placement.position, axis=1))
            read = placement.to_tracker(base) + rng.normal(size=base.shape) * sigma[:, None]
            for k, xyz in enumerate(read):
                rows.append({"joint": j + 1, **{f"q{i + 1}_deg": q[i] / DEG for i in range(robot.nq)},
                             "marker": f"R{k + 1}", "x_mm": xyz[0] / MM, "y_mm": xyz[1] / MM, "z_mm": xyz[2] / MM})
    return pd.DataFrame(rows)
