"""How a laser tracker reads a point: its noise, and the ways its readings go wrong.

A tracker measures a distance (interferometer or absolute distance meter) and two
encoder angles.  The distance error hardly grows with range, the angles' error
does, times the range: the error is an ellipsoid elongated across the line of
sight.  :class:`TrackerReadout` keeps the cell's overall scale (the cell's
``[tracker]`` σ(d) per coordinate, so the same mean variance per coordinate) and
splits it into a radial part ``radial_ratio`` times the transverse one; with
``isotropic=True`` it is the cell's model, every coordinate alike.

The distortions are readout effects, applied to readings in the order they are
taken:

* :class:`LineOfSightJumps`: beam-break re-acquisitions that land a reading off along the line of sight;
* :class:`FrameDrift`: the tracker's frame drifting in time (translation and a small rotation);
* :class:`ScaleError`: all distances from the tracker off by a relative error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayescal.cell.tracker import TrackerNoise

__all__ = ["TrackerReadout", "LineOfSightJumps", "FrameDrift", "ScaleError", "RADIAL_RATIO"]

RADIAL_RATIO = 0.35
"""Radial over transverse standard deviation.  ESTIMATE from an AT901-class datasheet:
the ADM/interferometer's ±10 μm against the angles' ±15 μm + 6 μm/m, at the 3-5 m of
the cell (about 10 μm against 35-45 μm)."""


def _line_of_sight(points: np.ndarray, tracker: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (k, 3) from the tracker to ``points`` and the distances (k,), m."""
    offset = np.asarray(points, dtype=float) - tracker
    distance = np.linalg.norm(offset, axis=-1)
    return offset / distance[..., np.newaxis], distance


@dataclass(frozen=True)
class TrackerReadout:
    """The tracker's random error on each reading.

    Parameters
    ----------
    cell_noise
        The cell's tracker model: its position and σ(d) per coordinate set the scale.
    isotropic
        Use the cell's model as is (independent, equal on every coordinate).
    radial_ratio
        Radial over transverse standard deviation when not isotropic.
    """

    cell_noise: TrackerNoise
    isotropic: bool = False
    radial_ratio: float = RADIAL_RATIO

    def read(self, points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(k, 3) readings (m) of true ``points`` (k, 3)."""
        points = np.asarray(points, dtype=float)
        sigma = self.cell_noise.sigma(points)
        if self.isotropic:
            return points + rng.normal(size=points.shape) * sigma[:, np.newaxis]
        # Same mean variance per coordinate as the cell: σ_r² + 2σ_t² = 3σ².
        transverse = sigma * math.sqrt(3.0 / (2.0 + self.radial_ratio**2))
        radial, _ = _line_of_sight(points, self.cell_noise.position)
        draws = rng.normal(size=points.shape) * transverse[:, np.newaxis]
        along = np.sum(draws * radial, axis=1)
        draws += ((self.radial_ratio - 1.0) * along)[:, np.newaxis] * radial
        return points + draws


@dataclass(frozen=True)
class LineOfSightJumps:
    """With probability ``fraction`` a reading is off by ``±U(low, high)`` m along the line of sight.

    The distance meter re-acquires the target after a broken beam onto a slightly
    different distance (a mis-seated reflector, a ghost return): the angles stay
    right, the distance does not.
    """

    fraction: float
    low: float
    high: float

    def apply(self, readings: np.ndarray, tracker: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """The readings (k, 3) with jumps, and a (k,) bool mask of those that jumped."""
        hit = rng.random(len(readings)) < self.fraction
        size = rng.uniform(self.low, self.high, len(readings)) * rng.choice([-1.0, 1.0], len(readings))
        direction, _ = _line_of_sight(readings, tracker)
        return readings + (hit * size)[:, np.newaxis] * direction, hit


@dataclass(frozen=True)
class FrameDrift:
    """The tracker's frame drifting relative to the robot's base with time ``t`` (s).

    Translation ``v·t + A·sin(2πt/P + ψ)·u`` (a steady thermal trend plus the
    hall's air-conditioning cycle) and a rotation ``ω·t`` about the tracker:
    a reading ``p`` becomes ``p + T(t) + Ω(t) × (p - tracker)``.
    """

    velocity: np.ndarray
    cycle_amplitude: np.ndarray
    cycle_period: float
    cycle_phase: float
    spin: np.ndarray

    @classmethod
    def draw(cls, rng: np.random.Generator, *, rate: float, cycle: float, period: float, spin_rate: float) -> FrameDrift:
        """A drift of ``rate`` m/s along a random direction, a ``cycle`` m cycle, ``spin_rate`` rad/s about a random axis."""
        def unit() -> np.ndarray:
            vector = rng.normal(size=3)
            return vector / np.linalg.norm(vector)

        return cls(rate * unit(), cycle * unit(), period, float(rng.uniform(0, 2 * math.pi)), spin_rate * unit())

    def apply(self, readings: np.ndarray, times: np.ndarray, tracker: np.ndarray) -> np.ndarray:
        """(k, 3) drifted readings (m) taken at ``times`` (k,) s."""
        t = np.asarray(times, dtype=float)[:, np.newaxis]
        shift = self.velocity * t + self.cycle_amplitude * np.sin(2 * math.pi * t / self.cycle_period + self.cycle_phase)
        return readings + shift + np.cross(self.spin * t, readings - tracker)


@dataclass(frozen=True)
class ScaleError:
    """Every distance from the tracker read ``1 + error`` times its true length (a wrong refractive index)."""

    error: float

    def apply(self, readings: np.ndarray, tracker: np.ndarray) -> np.ndarray:
        """(k, 3) readings (m) scaled about the tracker."""
        return tracker + (1.0 + self.error) * (readings - tracker)
