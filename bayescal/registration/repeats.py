"""A campaign's repeated readings of one physical state as reference nests of unknown position.

A marker read in one state at several times is, for the tracker's drift, what a fixed
reference nest is: a point that does not move while the frame does, its position a nuisance.
So the random walk of :mod:`bayescal.registration.nest_drift` takes both together, and a
campaign without nests but with times and repeats spread in time has its drift measured,
removed and reported exactly as from nests.  What counts as a *group*, from the campaign's
own columns:

* the reading times ``t0_s, t1_s`` (rows without them are left out: the order of the rows
  says nothing about how far apart they were);
* the loaded readings of one marker in the repeats of one configuration (``config``,
  ``marker``, ``repeat``), and likewise its unloaded readings after the first in time (a joint
  arriving at a configuration keeps its play on the side the move left it, and every later
  unloaded state follows a loading: the first would pass lost motion off as a drift);
* a group counts when its readings span at least :data:`DISTINCT_TIME`.

Intervals between an unloaded and a loaded reading are *not* evidence: a drift fitted to
the deflections over them rests on the deflections, whose load-correlated misfit (a link or
a tool mount bending) it would then absorb; on the independent generator that made a drift
fitted to the deflections tie with every link and tool compliance.

:func:`repeat_groups` gives the groups as :class:`~bayescal.cell.nests.Nests`;
:func:`fit_drift` fits the walk to the nests and the groups together.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.nests import Nests
from bayescal.cell.tracker import TrackerNoise
from bayescal.registration.nest_drift import NestDrift, fit_nest_drift

__all__ = ["repeat_groups", "fit_drift", "fit_anchors", "DISTINCT_TIME"]

DISTINCT_TIME = 1.0
"""Readings of a group closer in time than this (s) count as one instant: a tracker stamps to the second."""


def _after_first_unloaded(group: np.ndarray, state: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(R,) bool: every reading but each unloaded group's first in time (module documentation)."""
    first = np.zeros(group.size, dtype=bool)
    for g in np.unique(group[state == 0]):
        members = np.flatnonzero(group == g)
        first[members[np.argmin(times[members])]] = True
    return ~first


def repeat_groups(p0: np.ndarray, p1: np.ndarray, times: np.ndarray | None, config: np.ndarray, marker: np.ndarray,
                  source: str = "<memory>") -> Nests | None:
    """The groups of readings of one marker in one state at one configuration, as nests; None without any.

    Parameters
    ----------
    p0, p1 : numpy.ndarray
        (N, 3) each row's unloaded and loaded readings, m.
    times : numpy.ndarray or None
        (N, 2) their times, s (NaN: a row without times).
    config, marker : numpy.ndarray
        (N,) each row's configuration and marker.
    source : str
        The campaign's file, named in the groups' source.
    """
    if times is None:
        return None
    timed = np.all(np.isfinite(times), axis=1)
    points = np.concatenate([p0[timed], p1[timed]])
    at = np.concatenate([times[timed, 0], times[timed, 1]])
    state = np.repeat([0, 1], timed.sum())
    names = np.array([f"config {c} marker {m} {('unloaded', 'loaded')[s]}"
                      for c, m, s in zip(np.tile(config[timed], 2), np.tile(marker[timed], 2), state)], dtype=str)
    if names.size == 0:
        return None
    group = np.unique(names, return_inverse=True)[1].ravel()
    kept = _after_first_unloaded(group, state, at)
    low = np.full(group.max() + 1, np.inf)
    high = np.full(group.max() + 1, -np.inf)
    np.minimum.at(low, group[kept], at[kept])
    np.maximum.at(high, group[kept], at[kept])
    inside = kept & (high - low >= DISTINCT_TIME)[group]
    if not inside.any():
        return None
    rows = np.tile(np.flatnonzero(timed), 2)[inside]
    return Nests(names[inside], at[inside], points[inside], rows, f"{source} (repeats)")


def fit_drift(campaign: Campaign, tracker: TrackerNoise, nests: Nests | None = None, repeats: bool = True) -> NestDrift | None:
    """The frame's random walk fitted to ``nests`` and, with ``repeats``, the campaign's repeat groups together; None
    without either.

    Repeat groups are readings of the campaign itself: a walk fitted to them takes up some of their noise, which its
    removal then takes out of the deflections it is meant to leave alone.  With nests, they are therefore joined only
    when asked: on the twin at 0.2 mm/h (100 campaigns), the compliances after a removal fitted to nests and repeats
    covered 61.0 / 89.6 / 99.2 % at ±1/2/3 sd, against 63.6 / 92.8 / 99.4 % from the nests alone.
    """
    groups = None
    if repeats:
        groups = repeat_groups(campaign.p0, campaign.p1, campaign.times, campaign.config, campaign.marker, campaign.source)
    return fit_anchors(nests, groups, tracker)


def fit_anchors(nests: Nests | None, groups: Nests | None, tracker: TrackerNoise) -> NestDrift | None:
    """The walk fitted to reference nests and repeat groups (either may be None), counting each kind apart."""
    parts = [part for part in (nests, groups) if part is not None]
    if not parts:
        return None
    anchors = Nests(
        np.concatenate([part.name for part in parts]), np.concatenate([part.times for part in parts]),
        np.concatenate([part.position for part in parts]), np.concatenate([part.lines for part in parts]),
        " and ".join(part.source for part in parts),
    )
    count = lambda part: (0, 0) if part is None else (int(np.unique(part.name).size), len(part))  # noqa: E731
    (n_nests, n_nest_readings), (n_groups, n_group_readings) = count(nests), count(groups)
    return replace(fit_nest_drift(anchors, tracker), n_nests=n_nests, n_readings=n_nest_readings,
                   n_groups=n_groups, n_group_readings=n_group_readings)
