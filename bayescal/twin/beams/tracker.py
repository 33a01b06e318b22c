"""The generator's laser tracker: its noise law, its frame's drift in time, and the reference nests it reads.

Noise.  A tracker measures a range along its beam (an absolute distance meter) and two
angles across it (encoders), so its error is not the same in every direction: along the
line of sight the sd is ``RANGE_UM + RANGE_UM_PER_M · d``, across it (each of the two
directions) ``ANGLE_UM + ANGLE_UM_PER_M · d``, at distance ``d`` (m) from the tracker.  A
reflector seen off its axis reads worse (the prism's apex error and the beam's clipping):
both sds grow by the factor ``1 + INCIDENCE_GAIN (θ/60°)²`` at incidence θ.  The reflectors
on the tool are turned in their nests toward the tracker at each configuration (on Table III
the tool axis faces 61° to 179° away from the line to this tracker, and to the cell's), so θ
is the operator's aim error, up to :data:`AIM_ERROR_DEG`.  The numbers are ESTIMATES: across
the beam about 0.8 of a Leica AT901's datasheet error (±15 μm + 6 μm/m) at 4-6 m, along it
about a third of it, the range being the better-measured direction of such trackers.

Drift.  A tripod warming through the day carries the tracker's frame along: every reading of
a fixed point ``x`` at time ``t`` is moved to ``x + w(t) (T + Ω × (x − pivot))``, with
``w(t) = 1 − exp(−t/τ)`` (a thermal settling), ``T`` the final translation, ``Ω`` the final small
rotation (rad) about the tracker's own position ``pivot``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayescal.units import DEG, MM, UM

__all__ = ["TrackerLaw", "Drift", "POSITION_MM", "NEST_POSITIONS_MM", "AIM_ERROR_DEG"]

POSITION_MM = (2150.0, 2850.0, 420.0)
"""The tracker's place in the base frame (mm): its own, 150-420 mm from the cell's (2000, 3000, 0), on a tripod."""
RANGE_UM = 5.0
RANGE_UM_PER_M = 2.0
"""Sd along the line of sight: a constant part (μm) and one per metre of distance (μm/m); ESTIMATES."""
ANGLE_UM = 6.0
ANGLE_UM_PER_M = 6.0
"""Sd across the line of sight, each of two directions: constant (μm) and per metre (μm/m); ESTIMATES."""
INCIDENCE_GAIN = 0.5
"""Growth of both sds at 60° incidence on the reflector (the factor is 1.5 there); an ESTIMATE."""
AIM_ERROR_DEG = 20.0
"""Largest angle (deg) between a tool reflector's axis and the line to the tracker after the operator has turned
it toward the tracker; each reading's is uniform up to it (an ESTIMATE)."""
NEST_POSITIONS_MM = {"N1": (-1600.0, -2100.0, 40.0), "N2": (3600.0, -1400.0, 820.0), "N3": (400.0, 3400.0, 1650.0), "N4": (-2300.0, 1800.0, 300.0)}
"""Reference nests fixed around the cell (base frame, mm): on the floor, a column and a wall, 2.3 to 5.5 m from the tracker."""


@dataclass(frozen=True)
class TrackerLaw:
    """Noise of readings from the tracker at ``position`` (3,) m: sds along and across the line of sight (module documentation)."""

    position: np.ndarray

    def sigmas(self, points: np.ndarray, incidence: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Sd along and across the line of sight (m), shape (n,), of reflectors at ``points`` (n, 3) m seen at ``incidence`` (n,) rad."""
        distance = np.linalg.norm(points - self.position, axis=1)
        factor = 1.0 if incidence is None else 1.0 + INCIDENCE_GAIN * (np.asarray(incidence) / (60 * DEG)) ** 2
        along = (RANGE_UM + RANGE_UM_PER_M * distance) * UM * factor
        across = (ANGLE_UM + ANGLE_UM_PER_M * distance) * UM * factor
        return along, across

    def read(self, points: np.ndarray, rng: np.random.Generator, incidence: np.ndarray | None = None) -> np.ndarray:
        """(n, 3) readings of ``points`` (n, 3) m seen at ``incidence`` (n,) rad: each plus errors along and across its line of sight."""
        along, across = self.sigmas(points, incidence)
        sight = points - self.position
        sight /= np.linalg.norm(sight, axis=1)[:, None]
        # Any unit vector not parallel to the sight line gives the two directions across it.
        reference = np.where(np.abs(sight[:, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
        first = np.cross(sight, reference)
        first /= np.linalg.norm(first, axis=1)[:, None]
        second = np.cross(sight, first)
        z = rng.standard_normal((len(points), 3))
        return points + (along * z[:, 0])[:, None] * sight + (across * z[:, 1])[:, None] * first + (across * z[:, 2])[:, None] * second


DRIFT_TIME_CONSTANT_S = 7200.0
"""The tripod's thermal settling time (s): two hours, so a 5-hour campaign sees 92 % of the final drift."""
DRIFT_TRANSLATION_UM = 40.0
"""Final translation of the tracker's frame at magnitude 1 (μm): within the few tens of μm a tripod drifts in a day."""
DRIFT_ROTATION_URAD = 6.0
"""Final rotation at magnitude 1 (μrad): 21 μm at the robot's 3.5 m from the tracker."""


@dataclass(frozen=True)
class Drift:
    """The tracker frame's drift (module documentation): translation ``T`` (3,) m, rotation ``Ω`` (3,) rad, ``pivot`` (3,) m."""

    translation: np.ndarray
    rotation: np.ndarray
    pivot: np.ndarray
    time_constant: float = DRIFT_TIME_CONSTANT_S

    @classmethod
    def draw(cls, rng: np.random.Generator, magnitude: float, pivot: np.ndarray) -> Drift:
        """A drift of random directions with :data:`DRIFT_TRANSLATION_UM` and :data:`DRIFT_ROTATION_URAD` times ``magnitude``."""
        t, w = rng.standard_normal(3), rng.standard_normal(3)
        return cls(
            translation=magnitude * DRIFT_TRANSLATION_UM * UM * t / np.linalg.norm(t),
            rotation=magnitude * DRIFT_ROTATION_URAD * 1e-6 * w / np.linalg.norm(w),
            pivot=np.asarray(pivot, dtype=float),
        )

    def weight(self, t: np.ndarray) -> np.ndarray:
        """The drift's progress ``1 − exp(−t/τ)`` at times ``t`` (s)."""
        return -np.expm1(-np.asarray(t, dtype=float) / self.time_constant)

    def apply(self, points: np.ndarray, t: np.ndarray) -> np.ndarray:
        """(n, 3) readings of fixed ``points`` (n, 3) m at times ``t`` (n,) s, in the drifted frame (before noise)."""
        moved = self.translation + np.cross(self.rotation, points - self.pivot)
        return points + self.weight(t)[:, None] * moved

    def truth(self) -> dict:
        """The planted drift, in mm, μrad and s, for a study to compare an estimate with."""
        return {
            "law": "x(t) = x + (1 - exp(-t/time_constant_s)) (translation + rotation x (x - pivot))",
            "translation_mm": (self.translation / MM).tolist(),
            "rotation_urad": (self.rotation * 1e6).tolist(),
            "pivot_mm": (self.pivot / MM).tolist(),
            "time_constant_s": self.time_constant,
        }
