"""The critique's detection power: how strong each catalogue effect must be to be named, and the false-alarm rate.

Run ``python -m bayescal.reports.detection --config data/kr270.toml --plan
data/table3_plan.csv -o reports/detection.md`` to regenerate
``reports/detection.md``; every number in it is computed in that run by
:func:`~bayescal.studies.detection.detection_power` (and, with ``--geometry
POINTS.csv``, :func:`~bayescal.studies.geometry_critique.geometry_detection`).
``--plan-for EFFECT=PLAN.csv`` studies an effect on another plan (one that can
resolve it) as well.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.studies.detection import detection_power, markdown_table, power_threshold
from bayescal.twin.effects import EFFECTS
from bayescal.units import DEG
from bayescal.output import guard_outputs, write_atomically

__all__ = ["MAGNITUDES", "render_report", "main"]

MAGNITUDES: dict[str, tuple[float, ...]] = {
    "compensator": (5.0, 10.0, 20.0, 30.0, 50.0),
    "link_compliance": (0.25, 0.5, 1.0, 2.0),
    "tool_compliance": (0.3, 0.6, 1.0, 1.5),
    "backlash": (0.002, 0.005, 0.01, 0.015),
    "nonlinear_stiffness": (0.05, 0.1, 0.2, 0.3),
    "outliers": (0.0025, 0.005, 0.01, 0.02),
}
"""Magnitudes tried per effect (the effect's unit, docs/twin.md): from below the detection limit to past it."""

GEOMETRY_MAGNITUDES: dict[str, tuple[float, ...]] = {
    "tilt": (2 * DEG, 3.5 * DEG, 5 * DEG),
    "pivot_motion": (5e-9, 1e-8, 1.5e-8),
    "cylinder_slip": (0.003, 0.006, 0.01),
    "joint_scale": (0.001, 0.002, 0.004),
    "closed_loop": (10.0, 25.0, 50.0),
    "lever_bending": (1e-8, 2e-8, 4e-8),
}
"""Magnitudes of the geometry critique's planted effects (units of :data:`~bayescal.studies.geometry_critique.PLANTED`);
``lever_bending`` is outside its catalogue."""


def _geometry_section(points_path: str, executor, n_seeds: int, n_null: int, seed: int) -> list[str]:
    from bayescal.geometry.arcs import CompensatorGeometryModel, MarkerLayout, read_arc_points
    from bayescal.studies.geometry_critique import geometry_detection

    points = read_arc_points(points_path)
    layout = MarkerLayout.from_fit(CompensatorGeometryModel().fit(points), points)
    angles = np.unique(points.q2)
    began = time.perf_counter()
    table = geometry_detection(layout, angles, GEOMETRY_MAGNITUDES, n_seeds=n_seeds, n_null=n_null, seed=seed, executor=executor)
    seconds = time.perf_counter() - began
    header = "| effect | magnitude | unit | campaigns | first cause | named | misfit | unexplained |"
    lines = [
        f"## The geometry critique on `{Path(points_path).name}`'s angles",
        "",
        f"`bayescal critique --geometry` on marker points simulated with the layout fitted to `{points_path}` at its "
        f"{angles.size} angles with Table I's noise, each effect planted in its own physical terms "
        f"(`bayescal.studies.geometry_critique`); {n_seeds} campaigns per effect and magnitude, {n_null} without an "
        f"effect; {seconds:.0f} s. `lever_bending` is outside the catalogue: it should come out `unexplained`.",
        "",
        header,
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in table.itertuples():
        # angles at the edge in degrees, as everywhere else
        magnitude, unit = (row.magnitude / DEG, "deg") if row.unit == "rad" else (row.magnitude, row.unit)
        lines.append(
            f"| {row.effect} | {magnitude:g} | {unit} | {row.campaigns} | {100 * row.first_cause:.0f} % "
            f"| {100 * row.named:.0f} % | {100 * row.misfit:.0f} % | {100 * row.unexplained:.0f} % |"
        )
    return lines + [""]


def _section(title: str, plan: str, table: pd.DataFrame, seconds: float, n_seeds: int, repeats: int) -> list[str]:
    thresholds = power_threshold(table)
    lines = [
        f"## {title}",
        "",
        f"Plan `{plan}`, {repeats} repeats, {n_seeds} campaigns per effect and magnitude (the same seeds across magnitudes); "
        f"{seconds:.0f} s.",
        "",
        markdown_table(table),
        "",
        "Smallest magnitude tried at which the effect is named first in at least 90 % of the campaigns:",
        "",
    ]
    for name, magnitude in thresholds.items():
        default = EFFECTS[name].default
        found = "not reached at any magnitude tried" if magnitude is None else f"{magnitude:g} {EFFECTS[name].unit}"
        lines.append(f"- `{name}`: {found} (the twin's default: {default:g})")
    null = table[table["effect"] == "none"]
    if len(null):
        row = null.iloc[0]
        lines += [
            "",
            f"False alarms: {100 * row.misfit:.0f} % of {row.n} campaigns without any effect were called a misfit.",
        ]
    return lines + [""]


def render_report(
    config: str,
    plan: str,
    *,
    magnitudes: Mapping[str, Sequence[float]] = MAGNITUDES,
    other_plans: Mapping[str, str] | None = None,
    geometry_points: str | None = None,
    n_seeds: int = 20,
    n_null: int = 40,
    repeats: int = 3,
    seed: int = 0,
    workers: int | None = None,
) -> str:
    """The Markdown report: one table on ``plan`` for every effect, one per effect of ``other_plans`` on its own plan,
    and, with ``geometry_points`` (a Table-I-style CSV), one of the geometry critique at those points' angles."""
    other_plans = dict(other_plans or {})
    lines = [
        "# Detection power of the critique",
        "",
        "Each effect of the digital twin is planted at several magnitudes in simulated campaigns and `bayescal critique` "
        "is run on each, never told what was planted (`bayescal.studies.detection`). \"first cause\": the planted effect "
        "named first; \"named\": named at any step; \"misfit\": any cause named. The row `none` has no effect: its "
        "\"misfit\" column is the false-alarm rate. Generated by `python -m bayescal.reports.detection` "
        f"with `--config {config}`, root seed {seed}.",
        "",
    ]
    with ProcessPoolExecutor(workers) as executor:
        began = time.perf_counter()
        table = detection_power(config, plan, magnitudes, n_seeds=n_seeds, n_null=n_null, repeats=repeats, seed=seed, executor=executor)
        lines += _section(f"All effects on `{Path(plan).name}`", plan, table, time.perf_counter() - began, n_seeds, repeats)
        for name, path in other_plans.items():
            began = time.perf_counter()
            table = detection_power(
                config, path, {name: magnitudes[name]}, n_seeds=n_seeds, n_null=n_null, repeats=repeats, seed=seed, executor=executor
            )
            lines += _section(f"`{name}` on `{Path(path).name}`", path, table, time.perf_counter() - began, n_seeds, repeats)
        if geometry_points is not None:
            lines += _geometry_section(geometry_points, executor, n_seeds, n_null, seed)
    return "\n".join(lines)


def _plan_for(text: str) -> tuple[str, str]:
    name, _, path = text.partition("=")
    if name not in MAGNITUDES or not path:
        raise argparse.ArgumentTypeError(f"expected EFFECT=PLAN.csv with EFFECT one of {', '.join(MAGNITUDES)}, got {text!r}")
    return name, path


def main(argv: Sequence[str] | None = None) -> None:
    """Write the report: ``--config CELL.toml --plan PLAN.csv [--plan-for EFFECT=PLAN.csv ...] -o REPORT.md``."""
    parser = argparse.ArgumentParser(prog="python -m bayescal.reports.detection", description=__doc__.splitlines()[0])
    parser.add_argument("--config", required=True)
    parser.add_argument("--plan", required=True)
    parser.add_argument("--plan-for", type=_plan_for, action="append", default=[], metavar="EFFECT=PLAN.csv")
    parser.add_argument("--geometry", metavar="POINTS.csv", help="also study the geometry critique at these points' angles")
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--seeds", type=int, default=20, help="campaigns per effect and magnitude")
    parser.add_argument("--null", type=int, default=40, help="campaigns without an effect")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args(argv)
    inputs = {"the config": args.config, "the plan": args.plan, "the --geometry points": args.geometry}
    inputs |= {f"the {effect} plan": path for effect, path in args.plan_for}
    guard_outputs(inputs, {"--output": args.output})
    text = render_report(
        args.config,
        args.plan,
        other_plans=dict(args.plan_for),
        geometry_points=args.geometry,
        n_seeds=args.seeds,
        n_null=args.null,
        workers=args.workers,
    )
    write_atomically("--output", args.output, lambda path: path.write_text(text, encoding="utf-8"))


if __name__ == "__main__":
    main()
