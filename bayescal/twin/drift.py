"""The twin's clock: when it reads each marker and its reference nests, and how its tracker's frame drifts meanwhile.

A twin campaign is untimed unless asked for its times (:meth:`DigitalTwin.simulate_with_nests
<bayescal.twin.simulator.DigitalTwin.simulate_with_nests>`) or given a :class:`TrackerDrift`.
Its pace is :data:`TIMELINE`; its reference nests (:data:`NESTS`) are read before the first
configuration, while each load is hung and after it is removed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayescal.units import HOUR

__all__ = ["TrackerDrift", "TIMELINE", "NESTS", "reading_times", "nest_times"]

TIMELINE = {"marker": 15.0, "hang": 300.0, "unhang": 180.0, "move": 60.0}
"""Seconds from one marker's reading to the next, from a marker's unloaded reading to its loaded one, from the
loaded readings to the next repeat, and to the next configuration.  ESTIMATES: a 250 kg mass hung and settled in
5 min; Table III's 15 configurations × 3 repeats then take about 6.5 h."""

NESTS = {"R1": (3.0, -1.0, 0.0), "R2": (0.0, 3.0, 0.2), "R3": (-2.0, -2.0, 0.0)}
"""The twin cell's reference nests (base frame, m): three reflectors on the floor and a pillar around the robot.
ESTIMATES of a layout, spread around the cell and 2-4 m from the base."""


@dataclass(frozen=True)
class TrackerDrift:
    """The tracker's frame drifting at ``magnitude`` mm/h: a steady translation along :attr:`DIRECTION`, a steady turn
    about the tracker and a random walk of both, drawn per campaign.

    A reading ``p`` at time ``t`` becomes ``p + T(t) + Ω(t) × (p - tracker)``.
    """

    magnitude: float

    default = 0.2
    unit = "mm/h"
    DIRECTION = (0.6, -0.48, 0.64)
    """Unit direction of the steady translation."""
    TURN = (0.0, 0.6, 0.8)
    """Unit axis of the steady turn, at 0.05 mrad/h per mm/h (ESTIMATE: a tripod leg settling under a 3 m lever)."""
    WANDER = 0.5
    """The random walk's sd after one hour, as a fraction of the steady hourly amount (ESTIMATE of a hall's
    temperature wandering about its trend)."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.magnitude) and self.magnitude >= 0):
            raise ValueError(f"the drift needs a finite rate >= 0 in {self.unit}, got {self.magnitude:g}")

    def frame(self, times: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(k, 6) translation (m) and rotation (rad) of the frame at ``times`` (k,) s, zero at time 0."""
        t = np.asarray(times, dtype=float)
        rate = self.magnitude * 1e-3 / HOUR
        steady = np.concatenate([np.array(self.DIRECTION) * rate, np.array(self.TURN) * 0.05 * rate])
        unique, index = np.unique(np.append(t, 0.0), return_inverse=True)
        step_sd = self.WANDER * np.sqrt(np.diff(unique, prepend=unique[0]) / HOUR) * self.magnitude * 1e-3
        scale = np.repeat([1.0, 0.05], 3)
        walk = np.cumsum(rng.normal(size=(len(unique), 6)) * step_sd[:, None] * scale, axis=0)
        walk -= walk[index[-1]]
        return t[:, None] * steady + walk[index[:-1]]

    def apply(self, readings: np.ndarray, times: np.ndarray, tracker: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """(k, 3) the readings (k, 3) m taken at ``times`` (k,) s, moved by one draw of the drift."""
        frame = self.frame(times, rng)
        return readings + frame[:, :3] + np.cross(frame[:, 3:], readings - tracker)

    def describe(self) -> str:
        return f"drift={self.magnitude:g} {self.unit}"


def reading_times(n_configs: int, repeats: int, n_markers: int, passes: bool = False) -> np.ndarray:
    """(n_configs, repeats, n_markers, 2) the unloaded and loaded readings' times (s) at the pace of :data:`TIMELINE`:
    a configuration's repeats one after another, or with ``passes`` the plan measured once per repeat, so that a
    configuration's repeats lie a pass apart in time."""
    marker = TIMELINE["marker"] * np.arange(n_markers)
    per_repeat = TIMELINE["hang"] + TIMELINE["unhang"]
    if passes:
        slot = np.arange(repeats) * n_configs + np.arange(n_configs)[:, None]
        start = slot * (per_repeat + TIMELINE["move"])
    else:
        per_config = repeats * per_repeat + TIMELINE["move"]
        start = np.arange(n_configs)[:, None] * per_config + np.arange(repeats) * per_repeat
    t0 = start[:, :, None] + marker
    return np.stack([t0, t0 + TIMELINE["hang"]], axis=-1)


def nest_times(times: np.ndarray, n_nests: int, at: np.ndarray | None = None) -> np.ndarray:
    """(visits, n_nests) times (s) of the nests' readings: a visit before the first reading, and after every repeat's
    unloaded and loaded readings (``times`` as :func:`reading_times` gives them) of the configurations ``at`` marks
    ((n_configs,) bool; None: all)."""
    spacing = TIMELINE["marker"] * np.arange(1, n_nests + 1)
    last = np.sort(times[np.ones(len(times), dtype=bool) if at is None else at, :, -1, :].reshape(-1))
    starts = np.concatenate([[times[..., 0].min() - spacing[-1] - TIMELINE["marker"]], last])
    return starts[:, None] + spacing
