"""The critique's detection power: how strong each catalogue effect must be to be named, and the false-alarm rate.

:func:`render_report` renders the findings of
:func:`~bayescal_studies.studies.detection.detection_findings` (the twin's detection
power, the independent generator's campaigns side by side with it, the lack-of-fit
test's size and power against magnitude on that generator, and, given
marker points, the geometry critique's); it computes nothing.
``python -m bayescal_studies reports reports --only detection`` (``make reports``)
computes the findings (:func:`bayescal_studies.studies.paper_reports.paper_findings`) and
writes the report.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from bayescal_studies.studies.detection import DetectionFindings, markdown_table, power_threshold
from bayescal_studies.studies.independent_detection import INDEPENDENT_FIRST_SEED, LACK_OF_FIT_SIZE_LEVEL, independent_rates, lack_of_fit_power
from bayescal.twin.effects import EFFECTS as TWIN_EFFECTS
from bayescal.twin.independent import EFFECTS as INDEPENDENT_EFFECT_NAMES
from bayescal.units import DEG

__all__ = ["render_report"]

def _geometry_section(findings: DetectionFindings) -> list[str]:
    table, points = findings.geometry, findings.geometry_points
    header = "| effect | magnitude | unit | campaigns | first cause | named | misfit | unexplained |"
    lines = [
        f"## The geometry critique on `{Path(points).name}`'s angles",
        "",
        f"`bayescal critique --geometry` on marker points simulated with the layout fitted to `{points}` at its "
        f"{findings.geometry_angles} angles with Table I's noise, each effect planted in its own physical terms "
        f"(`bayescal_studies.studies.geometry_critique`); {findings.settings['n_seeds']} campaigns per effect and magnitude, "
        f"{findings.settings['n_null']} without an effect; {findings.seconds['geometry']:.0f} s. `lever_bending` is outside "
        "the catalogue: it should come out `unexplained`.",
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
        default = TWIN_EFFECTS[name].default
        found = "not reached at any magnitude tried" if magnitude is None else f"{magnitude:g} {TWIN_EFFECTS[name].unit}"
        lines.append(f"- `{name}`: {found} (the twin's default: {default:g})")
    null = table[table["effect"] == "none"]
    if len(null):
        row = null.iloc[0]
        lines += [
            "",
            f"False alarms: {100 * row.misfit:.0f} % of {row.n} campaigns without any effect were called a misfit.",
        ]
    return lines + [""]


def _side_by_side(findings: DetectionFindings) -> list[str]:
    """Power and false alarms of each cause family on the twin (its default magnitude) and on the independent generator."""
    twin = findings.twin
    rates = independent_rates(findings.independent)
    lines = [
        "## Side by side: the twin and the independent generator",
        "",
        "The critique's rules and thresholds were set on the twin; the independent generator "
        "(`bayescal.twin.independent`, `docs/independent.md`) writes its effects apart from the catalogue, draws its truths "
        "unlike the cell file and measures random plans of 6 q2 angles × 5 configurations × 3 repeats, 200-300 kg; "
        f"campaign k of each case is seeded {INDEPENDENT_FIRST_SEED} + k; {findings.seconds.get('independent', 0.0):.0f} s. "
        "\"right\": the planted family named first, or in a tie with the first, or `unexplained` for an effect outside the "
        "catalogue, or `adequate` without an effect; \"alone\": the planted family first, tied with nothing and contested by nothing; "
        "\"wrong alone\": a wrong first cause tied with nothing and contested by nothing; \"lack of fit\": "
        f"the repeats' F test rejecting the calibration's model at {LACK_OF_FIT_SIZE_LEVEL:g} (its size on the `none` row, its power on the others). "
        "An effect is planted at its default, or at the multiple of it (× m) that `INDEPENDENT_EFFECTS` sets so that its lack of fit "
        "is significant (next section), and then also at its default. The targets are "
        "misfit ≥ 95 %, right ≥ 90 %, wrong alone ≤ 5 % and, without an effect, adequate ≥ 95 %.",
        "",
        "| family | twin: named first at its default | twin: misfit | independent effect | campaigns | misfit | right | alone | wrong alone | lack of fit |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rates.itertuples():
        family = "none" if row.effect == "none" else INDEPENDENT_EFFECT_NAMES[row.effect].cause or "unexplained"
        at_default = twin[twin["effect"] == family]
        if family in TWIN_EFFECTS:
            at_default = at_default[np.isclose(at_default["magnitude"], TWIN_EFFECTS[family].default)]
        first = f"{100 * at_default['found_first'].iloc[0]:.0f} %" if len(at_default) and family != "none" else "—"
        misfit = f"{100 * at_default['misfit'].iloc[0]:.0f} %" if len(at_default) else "—"
        multiple = "" if row.effect == "none" or row.magnitude == 1.0 else f" × {row.magnitude:g}"
        lines.append(
            f"| {family} | {first} | {misfit} | `{row.effect}`{multiple} | {row.n} | {100 * row.misfit:.0f} % | {100 * row.right:.0f} % "
            f"| {100 * row.alone:.0f} % | {100 * row.wrong_single:.0f} % | {100 * row.lack_of_fit:.0f} % |"
        )
    return lines + [""]


def _power_section(findings: DetectionFindings) -> list[str]:
    """The calibration model's lack-of-fit test on the independent generator: its size and its power by magnitude."""
    power = lack_of_fit_power(findings.lack_of_fit)
    null = power[power["effect"] == "none"]
    lines = [
        "## The lack-of-fit test's size and power on the independent generator",
        "",
        "The repeats' F test of the calibration's model alone (the critique with an empty catalogue, "
        "`bayescal_studies.studies.independent_detection.independent_lack_of_fit`), on the campaigns of the side-by-side table's seeds with "
        "each effect at multiples of its default. The row `none` is the test's size; \"mean F\" is set against the statistic's mean "
        "under the model. `INDEPENDENT_EFFECTS` holds the magnitude at which each effect is tested against the detection "
        "targets: the smallest multiple in {1, 1.5, 2, 3} at which the test rejects at 5 % in at least 95 % of the "
        f"campaigns, the default where none does; {findings.seconds.get('lack_of_fit', 0.0):.0f} s.",
        "",
        "| effect | multiple of default | campaigns | p < 5 % | p < 1 % | mean F (under the model) |",
        "|---|---|---|---|---|---|",
    ]
    for row in power.itertuples():
        multiple = "—" if row.effect == "none" else f"{row.multiple:g}"
        lines.append(
            f"| {row.effect} | {multiple} | {row.n} | {100 * row.at_5:.1f} % | {100 * row.at_1:.1f} % "
            f"| {row.mean_statistic:.3f} ({row.expected_statistic:.3f}) |"
        )
    if len(null):
        row = null.iloc[0]
        # one binomial sd of the rejection count at a true 5 %
        sd = np.sqrt(row.n * LACK_OF_FIT_SIZE_LEVEL * (1 - LACK_OF_FIT_SIZE_LEVEL))
        lines += [
            "",
            f"Size: {round(row.at_5 * row.n)} of {row.n} campaigns without an effect rejected at 5 % "
            f"(a true 5 % gives {row.n * LACK_OF_FIT_SIZE_LEVEL:g} ± {sd:.1f}).",
        ]
    return lines + [""]


def render_report(findings: DetectionFindings) -> str:
    """The Markdown report of ``findings`` (:func:`~bayescal_studies.studies.detection.detection_findings`): rendering only."""
    settings = findings.settings
    lines = [
        "# Detection power of the critique",
        "",
        "Each effect of the digital twin is planted at several magnitudes in simulated campaigns and `bayescal critique` "
        "is run on each, never told what was planted (`bayescal_studies.studies.detection`). \"first cause\": the planted effect "
        "named first; \"named\": named at any step; \"misfit\": any cause named. The row `none` has no effect: its "
        "\"misfit\" column is the false-alarm rate. Generated by `python -m bayescal_studies reports` "
        f"with the cell `{findings.config}`, root seed {settings['seed']}.",
        "",
    ]
    lines += _side_by_side(findings)
    if findings.lack_of_fit is not None:
        lines += _power_section(findings)
    lines += _section(f"All effects on `{Path(findings.plan).name}`", findings.plan, findings.twin, findings.seconds["twin"], settings["n_seeds"], settings["repeats"])
    for name, (path, table) in findings.other_plans.items():
        lines += _section(f"`{name}` on `{Path(path).name}`", path, table, findings.seconds[name], settings["n_seeds"], settings["repeats"])
    if findings.geometry is not None:
        lines += _geometry_section(findings)
    return "\n".join(lines)
