"""The tracker's frame moving at a steady rate, and the walk of what the rate leaves.

The frame moves a point ``p`` to ``p + T(t) + Ω(t) × (p - c)`` (``c`` the tracker), as in
:mod:`bayescal.registration.nest_drift`.  Here ``(T, Ω)(t) = θ (t - t₀)`` plus a random walk:
``θ`` (6,) is a translation rate (m/s) and a turn rate (rad/s) shared by the whole campaign, and
the walk (:func:`~bayescal.registration.nest_drift.fit_nest_drift`) is fitted to what the rate
leaves.  The evidence is the same as the walk's: fixed points read at several times, each
point's position a nuisance.

*Why a rate.*  The walk knows the frame's change only over stretches that a point's readings
span.  A configuration's repeats read back to back span none of the interval between its first
unloaded and loaded readings, nor, fitted without one repeat, that repeat's.  A rate shared by
the campaign carries what every group shows to every interval.  On the independent generator's
thermal drift (0.2 mm/h, a 30 min cycle of 20 μm and a turn; six campaigns, seeds 9000-9005),
the drift it puts into the deflections, each repeat's from the other repeats, correlated with
the planted one at 0.49-0.82, the walk's alone at 0.27-0.45.

*Why the walk as well.*  A frame that wanders about its trend (the twin's drift, a random walk
about a steady rate) moves a deflection over a few minutes by more than the trend does; where
a group spans the interval, the walk follows that.  On the twin's drifting campaigns the
critique named `drift` first and alone in 10 % (40 campaigns, at twice the default 37.5 %)
with both, in 0 % (10 %) with the rate alone (``docs/critique.md``).

*Why not for removal.*  The rate's variance is a straight line's, and the walk fitted after it
does not carry the rate's uncertainty: :mod:`~bayescal.registration.nest_drift` measures and
removes the drift with its walk alone (its module documentation gives the coverage), and this
model gives the critique the *direction* a drift moves each deflection.

:func:`fit_steady_drift` fits the rate by weighted least squares with each point's position
profiled out, then the walk to the readings less the rate's motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayescal.cell.nests import Nests
from bayescal.cell.tracker import TrackerNoise
from bayescal.registration.nest_drift import NestDrift, fit_nest_drift, motion_matrix
from bayescal.units import HOUR, MM

__all__ = ["SteadyDrift", "fit_steady_drift"]


@dataclass(frozen=True)
class SteadyDrift:
    """The frame's steady rate over a campaign, and the walk of what it leaves.

    Attributes
    ----------
    rate : numpy.ndarray
        (6,) translation rate (m/s) and turn rate about the tracker (rad/s).
    cov : numpy.ndarray
        (6, 6) its covariance; zero in directions the readings do not fix, where the rate is zero.
    origin : float
        The time the rate's motion is counted from, s (the first reading).
    tracker : numpy.ndarray
        (3,) the tracker's position, m.
    wander : NestDrift
        The random walk fitted to the readings less the rate's motion.
    """

    rate: np.ndarray
    cov: np.ndarray
    origin: float
    tracker: np.ndarray
    wander: NestDrift

    def change(self, p0: np.ndarray, p1: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) the drift between readings ``p0`` and ``p1`` (N, 3) m taken at ``times`` (N, 2) s, and (N, 3, 3) its
        covariance (m²): the rate's and the walk's, taken as independent; zero for rows without times.

        The two stages' covariance is left out (the walk is fitted to readings the rate was fitted to): the critique
        reads the mean.
        """
        timed = np.all(np.isfinite(times), axis=1)
        t0, t1 = (np.where(timed, times[:, k], self.origin) - self.origin for k in (0, 1))
        sensitivity = motion_matrix(p1, self.tracker) * t1[:, None, None] - motion_matrix(p0, self.tracker) * t0[:, None, None]
        wander_mean, wander_cov = self.wander.change(p0, p1, times)
        return sensitivity @ self.rate + wander_mean, np.einsum("kai,ij,kbj->kab", sensitivity, self.cov, sensitivity) + wander_cov

    def to_json(self) -> dict:
        """The rate in mm/h and μrad/h with its sd, the translation's speed with its sd (to first order), and the walk's
        diffusion (μm²/s)."""
        sd = np.sqrt(np.diag(self.cov))
        speed = float(np.linalg.norm(self.rate[:3]))
        along = self.rate[:3] / speed if speed > 0 else np.zeros(3)
        return {
            "speed_mm_per_h": round(speed * HOUR / MM, 5),
            "speed_sd_mm_per_h": round(float(np.sqrt(along @ self.cov[:3, :3] @ along)) * HOUR / MM, 5),
            "rate_mm_per_h": (self.rate[:3] * HOUR / MM).round(5).tolist(),
            "rate_sd_mm_per_h": (sd[:3] * HOUR / MM).round(5).tolist(),
            "turn_urad_per_h": (self.rate[3:] * HOUR * 1e6).round(3).tolist(),
            "turn_sd_urad_per_h": (sd[3:] * HOUR * 1e6).round(3).tolist(),
            "diffusion_um2_per_s": float(self.wander.diffusion * 1e12),
        }


def fit_steady_drift(anchors: Nests, tracker: TrackerNoise) -> SteadyDrift:
    """The steady rate, and the walk of what it leaves, fitted to readings of fixed points (module documentation).

    Parameters
    ----------
    anchors : Nests
        Readings of fixed points (reference nests, or a campaign's repeat groups), each point's position unknown.
    tracker : TrackerNoise
        The tracker's noise model, which weighs the readings.
    """
    names, point = np.unique(anchors.name, return_inverse=True)
    origin = float(anchors.times.min())
    weight = 1.0 / tracker.sigma(anchors.position) ** 2
    travel = motion_matrix(anchors.position, tracker.position) * (anchors.times - origin)[:, None, None]
    # each point's position, of flat prior, profiled out: every reading less its point's weighted mean
    total = np.bincount(point, weight)
    mean_motion = np.zeros((len(names), 3, 6))
    np.add.at(mean_motion, point, weight[:, None, None] * travel)
    mean_position = np.zeros((len(names), 3))
    np.add.at(mean_position, point, weight[:, None] * anchors.position)
    motion = travel - mean_motion[point] / total[point, None, None]
    centred = anchors.position - mean_position[point] / total[point, None]
    information = np.einsum("k,kai,kaj->ij", weight, motion, motion)
    cov = np.linalg.pinv(information, hermitian=True)
    rate = cov @ np.einsum("k,kai,ka->i", weight, motion, centred)
    # readings that scatter about the rate more than the tracker's noise (a frame wandering about it, a robot's
    # repeatability between a state's visits) leave the rate less certain than the noise alone says
    freedom = 3 * len(anchors) - 3 * len(names) - np.linalg.matrix_rank(information)
    scatter = np.sum(weight * np.sum((centred - motion @ rate) ** 2, axis=1)) / max(freedom, 1)
    left = Nests(anchors.name, anchors.times, anchors.position - travel @ rate, anchors.lines, anchors.source)
    return SteadyDrift(rate, cov * max(scatter, 1.0), origin, np.asarray(tracker.position, dtype=float), fit_nest_drift(left, tracker))
