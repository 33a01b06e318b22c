"""How strong an effect must be for the critique to name it: detection power against magnitude, and false alarms.

:func:`detection_power` plants each effect of the digital twin at several
magnitudes in campaigns of a plan, runs :class:`~bayescal.critique.Critique`
on each (never told which effect was planted), and tabulates how often the
effect comes out as the first cause.  Magnitude 0 (the row ``none``) gives the
false-alarm rate.  The campaigns of one seed index share their random numbers
across magnitudes, and every campaign's seed is spawned from one
:class:`numpy.random.SeedSequence`, so the table does not depend on the
number of workers.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from os import PathLike

import numpy as np
import pandas as pd

__all__ = ["detection_power", "power_threshold", "markdown_table"]


def _one(effects: tuple[str, ...], rng: np.random.Generator, cell, plan, repeats: int) -> list[str]:
    """The causes the critique names in one simulated campaign (a task of :func:`~bayescal.studies.parallel.seeded_map`)."""
    from bayescal.critique import Critique
    from bayescal.twin.effects import parse_effect
    from bayescal.twin.simulator import DigitalTwin

    campaign = DigitalTwin(cell, [parse_effect(e) for e in effects]).simulate(plan, repeats, rng)
    with warnings.catch_warnings():
        # the plan's warnings (e.g. all loads parallel) are the same for every campaign of the study
        warnings.simplefilter("ignore", UserWarning)
        return Critique(cell).run(campaign).causes


def detection_power(
    config: str | PathLike[str],
    plan: str | PathLike[str],
    magnitudes: Mapping[str, Sequence[float]],
    *,
    n_seeds: int = 20,
    n_null: int = 40,
    repeats: int = 3,
    seed: int = 0,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """Fraction of campaigns in which the critique names each planted effect, by magnitude.

    Parameters
    ----------
    config, plan
        The cell TOML and the plan CSV the twin simulates.
    magnitudes
        Effect name to the magnitudes to plant (in the effect's unit, docs/twin.md).
    n_seeds
        Campaigns per effect and magnitude.
    n_null
        Campaigns without any effect (the false-alarm rate); 0 leaves that row out.
    repeats
        Repeats per configuration.
    seed
        Root of the :class:`numpy.random.SeedSequence` every campaign's seed is spawned from.
    executor
        Runs the campaigns (:func:`~bayescal.studies.parallel.seeded_map`; default a process pool).

    Returns
    -------
    pandas.DataFrame
        One row per effect and magnitude (effect ``none`` for the null campaigns):
        ``effect, magnitude, unit, n, found_first, found, misfit`` (fractions of ``n``):
        named as the first cause, named at all, any cause named.
    """
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.studies.parallel import seeded_map
    from bayescal.twin.effects import EFFECTS

    root = np.random.SeedSequence(seed)
    null_seeds, effect_seeds = root.spawn(2)
    shared = effect_seeds.spawn(n_seeds)
    cases = [("none", 0.0, (), null_seeds.spawn(n_null))] if n_null else []
    for name, values in magnitudes.items():
        for magnitude in values:
            cases.append((name, float(magnitude), (f"{name}={magnitude!r}",), shared))
    cell = load_cell(config)
    items = [effects for _, _, effects, seeds in cases for _ in seeds]
    streams = [s for _, _, _, seeds in cases for s in seeds]
    results = seeded_map(_one, items, streams, executor=executor, cell=cell, plan=read_plan(plan, cell.robot), repeats=repeats)
    records, start = [], 0
    for name, magnitude, _, seeds in cases:
        causes = results[start : start + len(seeds)]
        start += len(seeds)
        records.append(
            {
                "effect": name,
                "magnitude": magnitude,
                "unit": EFFECTS[name].unit if name in EFFECTS else "",
                "n": len(seeds),
                "found_first": float(np.mean([bool(c) and c[0] == name for c in causes])),
                "found": float(np.mean([name in c for c in causes])),
                "misfit": float(np.mean([bool(c) for c in causes])),
            }
        )
    return pd.DataFrame.from_records(records)


def power_threshold(table: pd.DataFrame, level: float = 0.9) -> dict[str, float | None]:
    """Per effect, the smallest magnitude tried at which it is the first cause in at least ``level`` of the campaigns."""
    out: dict[str, float | None] = {}
    for name, rows in table[table["effect"] != "none"].groupby("effect", sort=False):
        reached = rows[rows["found_first"] >= level]
        out[name] = float(reached["magnitude"].min()) if len(reached) else None
    return out


def markdown_table(table: pd.DataFrame) -> str:
    """The table in Markdown, fractions in percent."""
    lines = ["| effect | magnitude | unit | campaigns | first cause | named | misfit |", "|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        lines.append(
            f"| {row.effect} | {row.magnitude:g} | {row.unit} | {row.n} | {100 * row.found_first:.0f} % "
            f"| {100 * row.found:.0f} % | {100 * row.misfit:.0f} % |"
        )
    return "\n".join(lines)
