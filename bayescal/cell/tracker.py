"""Laser-tracker measurement noise.

The manufacturer's maximum permissible error of a Leica AT901-class tracker is
``U0 + U1·d`` with ``U0 = 15 μm`` and ``U1 = 6 μm/m`` at distance ``d`` from the
tracker (datasheet specification "±15 μm + 6 μm/m"); typical results are about
half of it.  The model draws independent Gaussian errors on each coordinate of
each measured point with standard deviation

    σ(p) = factor · (U0 + U1 · |p - tracker|).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["TrackerNoise"]


@dataclass(frozen=True)
class TrackerNoise:
    """Distance-dependent Gaussian noise of a laser tracker, SI units.

    Parameters
    ----------
    position
        (3,) tracker position in the robot base frame, m.
    U0
        Constant part of the maximum permissible error, m (15 μm, AT901 datasheet).
    U1
        Distance-proportional part, m per m (6 μm/m, AT901 datasheet).
    factor
        Standard deviation per coordinate as a fraction of the permissible error.
        The default 0.8 is the KR-270 cell's (``data/kr270.toml``): between the
        typical half and the datasheet bound, it gives the Table III campaign the
        linear-model precision of Klimchik et al., Table IV (``reports/twin.md``).
    """

    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    U0: float = 15e-6
    U1: float = 6e-6
    factor: float = 0.8

    def __post_init__(self) -> None:
        position = np.asarray(self.position, dtype=float).reshape(3)
        object.__setattr__(self, "position", position)
        for name in ("U0", "U1", "factor"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"TrackerNoise.{name} must be finite and non-negative, got {value}")

    def sigma(self, points) -> np.ndarray:
        """Standard deviation (m) of each coordinate of each point; shape of ``points`` without its last axis."""
        distance = np.linalg.norm(np.asarray(points, dtype=float) - self.position, axis=-1)
        return self.factor * (self.U0 + self.U1 * distance)

    def deflection_variance(self, unloaded, loaded) -> np.ndarray:
        """Variance (m²) of each coordinate of a deflection ``loaded - unloaded``: two independent readings.

        ``unloaded`` and ``loaded`` are ``(..., 3)`` points (m); the result has their shape without the last axis.
        """
        return self.sigma(unloaded) ** 2 + self.sigma(loaded) ** 2

    def sigma_range(self, *points) -> tuple[float, float]:
        """Smallest and largest sd per coordinate (m) of the readings at every point of the ``(..., 3)`` arrays ``points``."""
        sigma = np.concatenate([np.ravel(self.sigma(p)) for p in points])
        return float(sigma.min()), float(sigma.max())

    def measure(self, points, rng: np.random.Generator) -> np.ndarray:
        """The points as the tracker reads them: each coordinate plus an independent Gaussian error."""
        points = np.asarray(points, dtype=float)
        return points + rng.normal(size=points.shape) * self.sigma(points)[..., np.newaxis]
