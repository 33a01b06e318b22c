"""How strong an effect must be for the critique to name it: detection power against magnitude, and false alarms.

On the digital twin and on the independent generator.

:func:`detection_power` plants each effect of the digital twin at several
magnitudes in campaigns of a plan, runs :class:`~bayescal.critique.Critique`
on each (never told which effect was planted), and tabulates how often the
effect comes out as the first cause.  Magnitude 0 (the row ``none``) gives the
false-alarm rate.  The campaigns of one seed index share their random numbers
across magnitudes, and every campaign's seed is spawned from one
:class:`numpy.random.SeedSequence`, so the table does not depend on the
number of workers.

The same critique on campaigns of the independent generator, and the
lack-of-fit test's power on them, are :mod:`bayescal_studies.studies.independent_detection`'s.
:func:`detection_findings` gathers everything ``reports/detection.md`` renders.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from os import PathLike

import numpy as np
import pandas as pd

from bayescal_studies.studies.independent_detection import INDEPENDENT_EFFECTS, POWER_MULTIPLES, independent_detection, independent_lack_of_fit

__all__ = [
    "detection_power",
    "power_threshold",
    "markdown_table",
    "DetectionFindings",
    "detection_findings",
]


def _one(effects: tuple[str, ...], rng: np.random.Generator, cell, plan, repeats: int) -> list[str]:
    """The causes the critique names in one simulated campaign (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
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
        Runs the campaigns (:func:`~bayescal.design.parallel.seeded_map`; default a process pool).

    Returns
    -------
    pandas.DataFrame
        One row per effect and magnitude (effect ``none`` for the null campaigns):
        ``effect, magnitude, unit, n, found_first, found, misfit`` (fractions of ``n``):
        named as the first cause, named at all, any cause named.
    """
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.design.parallel import seeded_map

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
    return _rates(cases, results)


def _rates(cases: list[tuple], results: list[list[str]]) -> pd.DataFrame:
    """:func:`detection_power`'s table from its ``(name, magnitude, effects, seeds)`` cases and each campaign's causes, in order."""
    from bayescal.twin.effects import EFFECTS

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


@dataclass(frozen=True)
class DetectionFindings:
    """Everything ``reports/detection.md`` says, computed once.

    Attributes
    ----------
    config, plan : str
        The cell and the twin's plan.
    twin : pandas.DataFrame
        :func:`detection_power` on ``plan``.
    other_plans : dict
        Effect name to ``(plan path, its detection_power table)``.
    independent : pandas.DataFrame
        :func:`~bayescal_studies.studies.independent_detection.independent_detection`'s campaigns.
    geometry : pandas.DataFrame or None
        The geometry critique's detection table, with ``geometry_points`` and ``geometry_angles``.
    lack_of_fit : pandas.DataFrame or None
        :func:`~bayescal_studies.studies.independent_detection.independent_lack_of_fit`'s campaigns: the test's size and its power by magnitude.
    seconds : dict
        Wall time of each part.
    settings : dict
        Seeds, campaign counts and repeats.
    """

    config: str
    plan: str
    twin: pd.DataFrame
    other_plans: dict
    independent: pd.DataFrame
    geometry: pd.DataFrame | None = None
    geometry_points: str | None = None
    geometry_angles: int = 0
    lack_of_fit: pd.DataFrame | None = None
    seconds: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


def _geometry_power(
    points_path: str, magnitudes: Mapping[str, Sequence[float]], n_seeds: int, n_null: int, seed: int, executor: Executor | None
) -> tuple[pd.DataFrame, int]:
    """The geometry critique's detection table on the layout fitted to ``points_path``, and its number of q2 angles."""
    from bayescal.geometry.arcs import CompensatorGeometryModel, MarkerLayout, read_arc_points
    from bayescal_studies.studies.geometry_critique import geometry_detection

    points = read_arc_points(points_path)
    layout = MarkerLayout.from_fit(CompensatorGeometryModel().fit(points), points)
    angles = np.unique(points.q2)
    return geometry_detection(layout, angles, magnitudes, n_seeds=n_seeds, n_null=n_null, seed=seed, executor=executor), angles.size


def detection_findings(
    config: str,
    plan: str,
    magnitudes: Mapping[str, Sequence[float]],
    *,
    other_plans: Mapping[str, str] | None = None,
    geometry_points: str | None = None,
    geometry_magnitudes: Mapping[str, Sequence[float]] | None = None,
    independent_effects: Mapping[str, float] = INDEPENDENT_EFFECTS,
    power_multiples: Sequence[float] = POWER_MULTIPLES,
    n_seeds: int = 20,
    n_null: int = 40,
    n_independent: int = 40,
    repeats: int = 3,
    seed: int = 0,
    executor: Executor | None = None,
) -> DetectionFindings:
    """Run every study of ``reports/detection.md`` (twin, other plans, geometry, independent generator and the
    lack-of-fit test's power on it at ``power_multiples`` of each effect's default)."""
    import time

    seconds: dict[str, float] = {}
    began = time.perf_counter()
    twin = detection_power(config, plan, magnitudes, n_seeds=n_seeds, n_null=n_null, repeats=repeats, seed=seed, executor=executor)
    seconds["twin"] = time.perf_counter() - began
    others = {}
    for name, path in (other_plans or {}).items():
        began = time.perf_counter()
        others[name] = (
            path,
            detection_power(config, path, {name: magnitudes[name]}, n_seeds=n_seeds, n_null=n_null, repeats=repeats, seed=seed, executor=executor),
        )
        seconds[name] = time.perf_counter() - began
    geometry, angles = None, 0
    if geometry_points is not None:
        began = time.perf_counter()
        geometry, angles = _geometry_power(geometry_points, geometry_magnitudes or {}, n_seeds, n_null, seed, executor)
        seconds["geometry"] = time.perf_counter() - began
    began = time.perf_counter()
    independent = independent_detection(config, independent_effects, n_seeds=n_independent, n_null=n_independent, executor=executor)
    # effects tested above their defaults are also reported at them
    raised = {name: 1.0 for name, multiple in independent_effects.items() if multiple != 1.0}
    if raised:
        at_default = independent_detection(config, raised, n_seeds=n_independent, n_null=0, executor=executor)
        independent = pd.concat([independent, at_default], ignore_index=True)
    seconds["independent"] = time.perf_counter() - began
    began = time.perf_counter()
    power = independent_lack_of_fit(
        config, tuple(independent_effects), power_multiples, n_seeds=n_independent, n_null=n_independent, executor=executor
    )
    seconds["lack_of_fit"] = time.perf_counter() - began
    settings = {"n_seeds": n_seeds, "n_null": n_null, "n_independent": n_independent, "repeats": repeats, "seed": seed}
    return DetectionFindings(
        str(config), str(plan), twin, others, independent, geometry, geometry_points, angles, power, seconds, settings
    )
