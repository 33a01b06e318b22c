"""How often the sweep critique names a cause: on clean sweeps (false alarms) and with an effect planted.

Two generators: the digital twin's sweeps (:mod:`bayescal.twin.sweeps`, the
cell's isotropic noise, nothing planted), on which the critique's rule was set,
and the independent generator's (:mod:`bayescal.twin.independent.sweeps`, its
own reflectors, angles and anisotropic noise, effects in forms of its own), on
which it is measured.  Each file registers joints 1 and 2 of the cell's robot
from a tracker placed and turned at random.
"""

from __future__ import annotations

from collections.abc import Iterable
from concurrent.futures import Executor
from dataclasses import replace

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.critique.sweeps import critique_sweeps
from bayescal.registration.sweeps import Sweeps
from bayescal.design.parallel import seeded_map
from bayescal.twin.independent.sweeps import SweepEffect, independent_sweeps
from bayescal.twin.sweeps import random_placement, simulate_sweeps
from bayescal.units import DEG, MM

__all__ = ["FOUND_AS", "HOME_DEG", "sweep_critique_study", "false_alarms", "found"]

HOME_DEG = (0.0, -90.0, 90.0, 0.0, 45.0, 0.0)
"""Home pose of every simulated sweep file."""
FOUND_AS = {"gear_ratio": "angle_scale", "transmission": "transmission", "wobble": "wobble", "range_offset": "tracker_range",
            "tracker_scale": None}
"""The candidate each planted effect should be named as (None: no candidate can see it)."""


def _as_sweeps(table: pd.DataFrame) -> Sweeps:
    """A sweep table (as a file holds it) in SI."""
    q = table[[c for c in table.columns if c.startswith("q") and c.endswith("_deg")]].to_numpy() * DEG
    return Sweeps(table["joint"].to_numpy() - 1, q, table["marker"].to_numpy(dtype=str),
                  table[["x_mm", "y_mm", "z_mm"]].to_numpy() * MM, np.arange(2, len(table) + 2), "simulated sweeps")


def _one(index: int, rng: np.random.Generator, *, cell: Cell, generator: str, effect: str | None, magnitude: float) -> list[dict]:
    placement = random_placement(rng)
    if generator == "twin":
        table = simulate_sweeps(cell, placement, rng, home_deg=HOME_DEG)
    else:
        planted = SweepEffect.draw(effect, magnitude, rng) if effect else None
        table = independent_sweeps(cell, placement, rng, home_deg=HOME_DEG, effect=planted)
    critique = critique_sweeps(_as_sweeps(table), replace(cell.tracker, position=np.zeros(3)))
    rows = []
    for joint, result in critique.joints.items():
        first = result.causes[0] if result.causes else None
        for name, row in result.evidence.iterrows():
            rows.append({"seed": index, "joint": joint + 1, "candidate": name, "delta_elpd": row["delta_elpd"], "se": row["se"],
                         "named": bool(row["named"]), "first": name == first, "estimate": row["estimate"]})
    return rows


def sweep_critique_study(cell: Cell, files: int | Iterable[int], *, generator: str = "twin", effect: str | None = None,
                         magnitude: float = 1.0, seed: int = 2026, executor: Executor | None = None) -> pd.DataFrame:
    """One row per file, joint and candidate: the held-out gain, its SE, whether named and whether named first.

    Parameters
    ----------
    cell
        The robot and the tracker's noise.
    files
        How many sweep files, or their indices.
    generator
        ``"twin"`` (nothing planted) or ``"independent"``.
    effect, magnitude
        The independent generator's planted effect (:data:`~bayescal.twin.independent.sweeps.SWEEP_EFFECTS`) and
        its multiple of the default size; None: clean.
    seed, executor
        As :func:`~bayescal.design.parallel.seeded_map`.
    """
    if generator not in ("twin", "independent") or (generator == "twin" and effect is not None):
        raise ValueError("generator is 'twin' (clean) or 'independent' (clean or with an effect)")
    items = range(files) if isinstance(files, int) else list(files)
    batches = seeded_map(_one, items, seed, executor=executor, cell=cell, generator=generator, effect=effect, magnitude=magnitude)
    return pd.DataFrame([row for batch in batches for row in batch])


def false_alarms(table: pd.DataFrame, floor: float | None = None, z: float | None = None) -> float:
    """Share of files in which any candidate is named, by the critique's rule or by ``floor`` (nats) and ``z`` if given."""
    named = table["named"] if floor is None else (table["delta_elpd"] > floor) & (table["delta_elpd"] > z * table["se"])
    return float(named.groupby(table["seed"]).any().mean())


def found(table: pd.DataFrame, effect: str) -> dict[str, float]:
    """Per joint and over both: the share of files where the planted effect's candidate is named first."""
    candidate = FOUND_AS[effect]
    first = table[table["candidate"] == candidate].set_index(["seed", "joint"])["first"] if candidate else None
    if first is None:
        return {"any_named": float(table.groupby("seed")["named"].any().mean())}
    per_joint = first.groupby("joint").mean()
    return {**{f"joint_{j}": float(v) for j, v in per_joint.items()}, "either_joint": float(first.groupby("seed").any().mean())}
