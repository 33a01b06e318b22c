"""The tracker's drift from the campaign's own evidence: one physical state read again later.

A campaign shows a drift of the tracker's frame apart from its deflections only where it
reads the same physical state more than once at different times.  What counts as that
evidence, from the campaign's own columns:

* the reading times ``t0_s, t1_s`` (without them no reading can be placed in time, and
  the order of the rows says nothing about how far apart they were);
* a *group*: the loaded readings of one marker in the repeats of one configuration
  (``config``, ``marker``, ``repeat``), and likewise its unloaded readings after the first
  (a joint arriving at a configuration keeps its play on the side the move left it, and
  every later unloaded state follows a loading); a group of two or more readings at
  distinct times holds its marker still while the frame moves.

Within a group the readings differ by the drift between their times and the tracker's
noise; six rates (a translation and a small rotation about the tracker, both steady in
time) are fitted to those differences and nothing else.  Intervals between the unloaded
and the loaded reading that vary from row to row are not counted: a drift fitted to the
deflections over them still rests on the deflections, whose load-correlated misfit (a link
or a tool mount bending) it then absorbs; on the independent generator that made a drift
fitted to the deflections tie with every link and tool compliance.

:func:`drift_evidence` returns the rates with their covariance, or why the campaign cannot
show a drift and how to make it able to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

from bayescal.cell.config import Cell
from bayescal.critique.covariates import Rows
from bayescal.units import MM

__all__ = ["DriftEvidence", "drift_evidence", "drift_deflection", "MAKE_TESTABLE", "DISTINCT_TIME"]

DISTINCT_TIME = 1.0
"""Readings of a group closer in time than this (s) count as one instant: a tracker stamps to the second."""
HOUR = 3600.0
MRAD = 1e-3
MAKE_TESTABLE = (
    "read two to four reference nests fixed around the cell every 5-15 min and give them with --nests "
    "(nest, t_s, x_mm, y_mm, z_mm) with the readings' times (t0_s, t1_s), which measures the drift and removes it "
    "(bayescal plan --nests K marks where to read them); "
    "or give the times and repeat configurations at times spread over the campaign (read each configuration "
    "again later rather than back to back), so that a marker's readings of one state taken apart in time show it"
)
"""What to change in a campaign whose readings cannot show a drift."""


@dataclass(frozen=True)
class DriftEvidence:
    """The tracker's drift as the campaign's repeated readings of one state show it.

    Attributes
    ----------
    testable : bool
        Whether the campaign holds groups of readings of one state at distinct times enough to fit the six rates.
    reason : str
        What the evidence is, or why there is none and how to get it.
    rate : numpy.ndarray
        (6,) translation rate (m/s) and rotation rate about the tracker (rad/s), base axes; zeros when not testable.
    cov : numpy.ndarray
        (6, 6) their covariance.
    tracker : numpy.ndarray
        (3,) the tracker's position, m.
    n_groups, n_readings : int
        Groups with readings at distinct times, and their readings.
    span_s : float
        Largest spread of times within a group, s.
    p_value : float
        F test of all six rates zero against the scatter within the groups (NaN when not testable).
    """

    testable: bool
    reason: str
    rate: np.ndarray
    cov: np.ndarray
    tracker: np.ndarray
    n_groups: int = 0
    n_readings: int = 0
    span_s: float = 0.0
    p_value: float = float("nan")

    def to_json(self) -> dict:
        payload = {"testable": self.testable, "evidence": self.reason}
        if not self.testable:
            return payload
        sd = np.sqrt(np.diag(self.cov))
        return payload | {
            "groups": self.n_groups,
            "readings": self.n_readings,
            "span_s": round(self.span_s, 1),
            "translation_mm_per_h": [round(float(v), 4) for v in self.rate[:3] * HOUR / MM],
            "translation_sd_mm_per_h": [round(float(v), 4) for v in sd[:3] * HOUR / MM],
            "rotation_mrad_per_h": [round(float(v), 5) for v in self.rate[3:] * HOUR / MRAD],
            "rotation_sd_mrad_per_h": [round(float(v), 5) for v in sd[3:] * HOUR / MRAD],
            "p_value": round(self.p_value, 6),
        }


def _frame_motion(points: np.ndarray, times: np.ndarray, tracker: np.ndarray) -> np.ndarray:
    """(n, 3, 6) how a reading at ``points`` (n, 3) taken at ``times`` (n,) moves per unit of the six rates."""
    lever = points - tracker
    # w × lever = -lever × w: the cross-product matrix of -lever
    cross = np.zeros((len(points), 3, 3))
    cross[:, 0, 1], cross[:, 0, 2] = lever[:, 2], -lever[:, 1]
    cross[:, 1, 0], cross[:, 1, 2] = -lever[:, 2], lever[:, 0]
    cross[:, 2, 0], cross[:, 2, 1] = lever[:, 1], -lever[:, 0]
    motion = np.concatenate([np.broadcast_to(np.eye(3), cross.shape), cross], axis=2)
    return motion * times[:, np.newaxis, np.newaxis]


def _after_first_unloaded(group: np.ndarray, state: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``(R,)`` bool: every reading but each unloaded group's first in time.

    A joint arriving at a configuration keeps the side of its play the move left it on; every later state
    follows a loading and a joint's play returns to the same side each time: a configuration's first
    unloaded reading is no repeat of its later ones (lost motion would pass for a drift).
    """
    first = np.zeros(group.size, dtype=bool)
    for g in np.unique(group[state == 0]):
        members = np.flatnonzero(group == g)
        first[members[np.argmin(times[members])]] = True
    return ~first


def drift_evidence(rows: Rows, cell: Cell) -> DriftEvidence:
    """The six drift rates fitted to the campaign's readings of one state repeated in time (rows without times are ignored)."""
    tracker = np.asarray(cell.tracker.position, dtype=float)
    none = np.zeros(6), np.zeros((6, 6)), tracker
    timed = np.all(np.isfinite(rows.times), axis=1)
    if not timed.any():
        return DriftEvidence(False, "the campaign gives no reading times: " + MAKE_TESTABLE, *none)
    points = np.concatenate([rows.position[timed], (rows.position + rows.y)[timed]])
    times = np.concatenate([rows.times[timed, 0], rows.times[timed, 1]])
    state = np.repeat([0, 1], timed.sum())
    keys = np.stack([np.tile(rows.config[timed], 2), np.tile(np.unique(rows.marker, return_inverse=True)[1][timed], 2), state], axis=1)
    group = np.unique(keys, axis=0, return_inverse=True)[1].ravel()
    kept = _after_first_unloaded(group, state, times)
    spread = np.array([np.ptp(times[kept & (group == g)]) if np.any(kept & (group == g)) else 0.0 for g in range(group.max() + 1)])
    useful = spread >= DISTINCT_TIME
    inside = useful[group] & kept
    n_groups = int(useful.sum())
    if n_groups == 0:
        return DriftEvidence(False, "no marker's state is read twice at different times: " + MAKE_TESTABLE, *none)
    points, times, group = points[inside], times[inside], np.unique(group[inside], return_inverse=True)[1]
    sigma = cell.tracker.sigma(points)
    design = _frame_motion(points, times, tracker)
    # each group's own position is a nuisance: differences from the group's weighted mean carry the drift alone
    weight = 1.0 / sigma**2
    total = np.bincount(group, weight)

    def centred(values: np.ndarray) -> np.ndarray:
        flat = values.reshape(len(values), -1)
        mean = np.stack([np.bincount(group, weight * column) for column in flat.T], axis=1) / total[:, np.newaxis]
        return (flat - mean[group]).reshape(values.shape)

    X = (centred(design) / sigma[:, np.newaxis, np.newaxis]).reshape(-1, 6)
    y = (centred(points) / sigma[:, np.newaxis]).reshape(-1)
    # columns in comparable units (rad/s about the tracker against m/s) before judging the rank
    norm = np.linalg.norm(X, axis=0)
    dof = y.size - 3 * n_groups - 6
    if np.any(norm == 0) or np.linalg.matrix_rank(X / norm) < 6 or dof < 1:
        return DriftEvidence(False, "the readings repeated in time are too few to fit a drift: " + MAKE_TESTABLE, *none)
    unit = X / norm
    solution, *_ = np.linalg.lstsq(unit, y, rcond=None)
    rate = solution / norm
    residual = y - unit @ solution
    scale = float(residual @ residual) / dof
    cov = scale * np.linalg.inv(unit.T @ unit) / np.outer(norm, norm)
    fitted = unit @ solution
    statistic = float(fitted @ fitted) / 6 / scale
    span = float(spread[useful].max())
    reason = (
        f"{n_groups} groups of readings of one marker in one state ({inside.sum()} readings), "
        f"repeated up to {span / 60:.0f} min apart"
    )
    return DriftEvidence(
        True, reason, rate, cov, tracker, n_groups, int(inside.sum()), span, float(special.fdtrc(6, dof, statistic))
    )


def drift_deflection(evidence: DriftEvidence, rows: Rows) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) the drift the evidence puts into each row's deflection (m), and (N, 3) its standard deviation;
    zero for rows without times (poses to predict)."""
    timed = np.all(np.isfinite(rows.times), axis=1)
    # the frame's motion over the interval between the two readings, about the unloaded reading: the rotation
    # accumulated since an arbitrary origin of time turns the deflection itself by well under a micrometre
    interval = np.where(timed, rows.times[:, 1] - rows.times[:, 0], 0.0)
    change = _frame_motion(rows.position, interval, evidence.tracker)
    mean = change @ evidence.rate
    sd = np.sqrt(np.einsum("nij,jk,nik->ni", change, evidence.cov, change))
    return mean, sd
