"""When each reading is taken: the order of a campaign's steps and a realistic clock for them.

A step is one repeat of one configuration: read every marker unloaded, hang the mass,
let it settle, read every marker loaded, take the mass off.  Moving to a configuration
and letting the arm settle comes before its first step.  The steps run either
``"together"`` (a configuration's repeats one after the other, as ``docs/measuring.md``
describes) or in ``"passes"`` (the whole plan, then again), so that repeats of a
configuration are read hours apart.  Reference nests are read in a round at the start,
at the first break between steps once :data:`NEST_INTERVAL_S` has passed, and at the end.
All durations are ESTIMATES of a careful crew with a hoist, stated with their spread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Step", "Schedule", "plan_schedule", "ORDERS"]

ORDERS = ("together", "passes")
MOVE_S = (60.0, 120.0)
"""Moving to a configuration and letting the arm settle (s, uniform range)."""
READ_S = (7.0, 9.0)
"""One reflector's reading, the tracker turning to it and averaging (s)."""
HANG_S = (180.0, 300.0)
"""Hoisting the mass onto the hook, freeing the sling and letting the swing die out (s)."""
REMOVE_S = (90.0, 150.0)
"""Lifting the mass off again (s)."""
NEST_READ_S = (10.0, 14.0)
"""Turning to a reference nest and reading it (s)."""
NEST_INTERVAL_S = 420.0
"""Least time between two rounds of the reference nests (s): within the 5-15 min that catches a tripod's drift."""


@dataclass(frozen=True)
class Step:
    """One repeat of one configuration: plan row ``config`` (0-based), ``repeat`` (0-based), reading times (s) of each marker."""

    config: int
    repeat: int
    moved: bool
    unloaded: np.ndarray
    loaded: np.ndarray


@dataclass(frozen=True)
class Schedule:
    """The campaign's steps in the order measured, and the nest readings (name index, time in s) in rounds."""

    steps: tuple[Step, ...]
    nest_times: np.ndarray
    nest_index: np.ndarray


def _readings(t: float, n: int, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Times of ``n`` consecutive readings from ``t`` and the time after the last."""
    times = t + np.concatenate([[0.0], np.cumsum(rng.uniform(*READ_S, n - 1))])
    return times, float(times[-1] + rng.uniform(*READ_S))


def _nest_round(t: float, n_nests: int, rng: np.random.Generator, times: list, index: list) -> float:
    """Read every nest from ``t`` on (appended to ``times``, ``index``); the time after the round."""
    for nest in range(n_nests):
        times.append(t)
        index.append(nest)
        t += rng.uniform(*NEST_READ_S)
    return t


def plan_schedule(n_configs: int, repeats: int, n_markers: int, n_nests: int, order: str, rng: np.random.Generator) -> Schedule:
    """The steps of a plan of ``n_configs`` measured ``repeats`` times in ``order``, with a clock from 0 s.

    Nests (``n_nests`` of them; 0 for none) are read between steps (module documentation).
    """
    if order == "together":
        sequence = [(c, r) for c in range(n_configs) for r in range(repeats)]
    else:
        sequence = [(c, r) for r in range(repeats) for c in range(n_configs)]
    steps, nest_times, nest_index = [], [], []
    t, last_round = 0.0, 0.0
    if n_nests:
        t = _nest_round(t, n_nests, rng, nest_times, nest_index)
    previous = None
    for config, repeat in sequence:
        moved = config != previous
        if moved:
            t += rng.uniform(*MOVE_S)
        unloaded, t = _readings(t, n_markers, rng)
        t += rng.uniform(*HANG_S)
        loaded, t = _readings(t, n_markers, rng)
        t += rng.uniform(*REMOVE_S)
        steps.append(Step(config, repeat, moved, unloaded, loaded))
        previous = config
        if n_nests and t - last_round >= NEST_INTERVAL_S:
            last_round = t
            t = _nest_round(t, n_nests, rng, nest_times, nest_index)
    if n_nests and nest_times[-1] < steps[-1].loaded[-1]:
        _nest_round(t, n_nests, rng, nest_times, nest_index)
    return Schedule(tuple(steps), np.array(nest_times), np.array(nest_index, dtype=int))
