"""The tracker's drift from the campaign's own evidence: one physical state read again later.

A campaign shows a drift of the tracker's frame apart from its deflections only where it
reads the same physical state more than once at different times: its *repeat groups*
(:mod:`bayescal.registration.repeats`: the loaded readings of one marker in the repeats of
one configuration, and its unloaded readings after the first, with the reading times
``t0_s, t1_s``).  The drift is the model of :mod:`bayescal.registration.steady_drift`: the
frame's translation and small rotation about the tracker at a rate shared by the campaign, and
a random walk of what the rate leaves, each group's position a nuisance as a reference nest's
is.  Intervals between the unloaded and the loaded reading are not evidence, so a drift
measured here cannot take up a load-correlated misfit of the deflections.

The walk alone, which measures and removes a drift (:mod:`bayescal.registration.nest_drift`),
knows the frame's change only over stretches a group spans.  When it gave this column,
repeats read back to back left a configuration's first repeat without any, and, fitted
without a repeat, that repeat's; on the independent generator's thermal drift `drift` was
named first and alone in 35 % of campaigns (``docs/critique.md``).  The rate carries what
every group shows to every interval; the walk follows a frame that wanders about it where a
group spans the interval.

:func:`drift_evidence` returns the drift fitted to the groups, or why the campaign cannot
show a drift and how to make it able to.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from bayescal.cell.config import Cell
from bayescal.critique.covariates import Rows

if TYPE_CHECKING:
    # The drift's models (and SciPy with them) are imported where a campaign's drift is fitted, not where a critique's
    # results are read back.
    from bayescal.registration.steady_drift import SteadyDrift

__all__ = ["DriftEvidence", "drift_evidence", "drift_deflection", "MAKE_TESTABLE"]

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
        Whether the campaign holds a group of readings of one state at distinct times.
    reason : str
        What the evidence is, or why there is none and how to get it.
    track : SteadyDrift or None
        The frame's steady rate and the walk of what it leaves, fitted to the groups; None when not testable, or not
        fitted (``drift`` left out of a critique's catalogue).
    groups, readings : int
        Repeat groups and their readings.
    span_s : float
        Largest spread of times within a group, s.
    held_out : tuple
        ``(repeat, drift)`` pairs: the drift fitted without that repeat's readings (None: no group left), from which
        that repeat's rows take theirs.
    """

    testable: bool
    reason: str
    track: SteadyDrift | None = None
    groups: int = 0
    readings: int = 0
    span_s: float = 0.0
    held_out: tuple[tuple[int, SteadyDrift | None], ...] = ()

    def to_json(self) -> dict:
        payload = {"testable": self.testable, "evidence": self.reason}
        if not self.testable:
            return payload
        counts = {"groups": self.groups, "readings": self.readings, "span_s": round(self.span_s, 1)}
        return payload | counts | ({} if self.track is None else self.track.to_json())


@dataclass(frozen=True)
class _Timed:
    """A campaign's rows with reading times, compared by ``key``, a digest of their content: the rows extended by poses
    to predict (which have no times) give the campaign's evidence, fitted once."""

    key: bytes
    rows: Rows = field(compare=False)


def _timed(rows: Rows) -> _Timed:
    timed = rows.take(np.flatnonzero(np.all(np.isfinite(rows.times), axis=1)))
    arrays = (timed.position, timed.y, timed.times, timed.config, timed.repeat)
    # names joined, not the array's bytes: joined to rows of longer names, the array is padded wider
    names = "\0".join(timed.marker.tolist()).encode()
    return _Timed(hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays) + names).digest(), timed)


def drift_evidence(rows: Rows, cell: Cell, fitted: bool = True) -> DriftEvidence:
    """The frame's steady rate and walk fitted to the campaign's repeat groups (rows without times are ignored).

    Cached per content of the rows with times: the critique asks for it with every model that holds ``drift``, and
    with the campaign's rows extended by the test pose.  ``fitted=False``: whether the campaign can show a drift and its
    groups, without the fits (one per repeat held out and one of all: 4 s of a critique's 4.3 s on an independent-generator
    campaign of 90 readings per repeat), for a critique that does not try ``drift``.
    """
    return _evidence(_timed(rows), cell, fitted)


@lru_cache(maxsize=4)
def _evidence(timed: _Timed, cell: Cell, fitted: bool) -> DriftEvidence:
    """:func:`drift_evidence` of the rows with times."""
    from bayescal.registration.repeats import repeat_groups
    from bayescal.registration.steady_drift import fit_steady_drift

    rows = timed.rows
    if len(rows) == 0:
        return DriftEvidence(False, "the campaign gives no reading times: " + MAKE_TESTABLE)
    groups = repeat_groups(rows.position, rows.position + rows.y, rows.times, rows.config, rows.marker)
    if groups is None:
        return DriftEvidence(False, "no marker's state is read twice at different times: " + MAKE_TESTABLE)
    names, group = np.unique(groups.name, return_inverse=True)
    low, high = np.full(len(names), np.inf), np.full(len(names), -np.inf)
    np.minimum.at(low, group, groups.times)
    np.maximum.at(high, group, groups.times)
    spread = high - low
    reason = (
        f"{len(names)} groups of readings of one marker in one state ({len(groups)} readings), "
        f"repeated up to {spread.max() / 60:.0f} min apart"
    )
    if not fitted:
        return DriftEvidence(True, reason, None, len(names), len(groups), float(spread.max()))
    return DriftEvidence(True, reason, fit_steady_drift(groups, cell.tracker), len(names), len(groups), float(spread.max()),
                         _held_out(rows, cell))


def _held_out(rows: Rows, cell: Cell) -> tuple[tuple[int, SteadyDrift | None], ...]:
    """The drift fitted without each repeat's readings in turn.

    A row's readings are in the groups and in its deflection.  A walk of several hundred knots fitted to them took up
    their noise, and a drift column built from it fitted the deflections' noise (a campaign without any drift had
    `drift` named).  Each repeat's rows take their drift from the one fitted to the other repeats.
    """
    from bayescal.registration.repeats import repeat_groups
    from bayescal.registration.steady_drift import fit_steady_drift

    folds = []
    for repeat in np.unique(rows.repeat):
        other = rows.repeat != repeat
        groups = repeat_groups(rows.position[other], (rows.position + rows.y)[other], rows.times[other],
                               rows.config[other], rows.marker[other])
        folds.append((int(repeat), None if groups is None else fit_steady_drift(groups, cell.tracker)))
    return tuple(folds)


def drift_deflection(evidence: DriftEvidence, rows: Rows) -> tuple[np.ndarray, np.ndarray]:
    """(N, 3) the drift the evidence puts into each row's deflection (m), from the drift fitted without the row's repeat,
    and (N, 3) its standard deviation; zero for rows without times (poses to predict) or whose repeat leaves no group."""
    mean, sd = np.zeros((len(rows), 3)), np.zeros((len(rows), 3))
    for repeat, track in evidence.held_out:
        mine = rows.repeat == repeat
        if track is not None:
            change, cov = track.change(rows.position[mine], (rows.position + rows.y)[mine], rows.times[mine])
            mean[mine], sd[mine] = change, np.sqrt(np.einsum("kii->ki", cov))
    return mean, sd
