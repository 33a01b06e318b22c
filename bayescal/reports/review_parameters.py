"""The review's sections on the identified parameters: their table beside the published one, what the data
cannot identify and why, and their posterior pairs.

Each renders what :class:`~bayescal.inference.results.ElastostaticResults` gives (summarised once in
:class:`_Facts`) onto the :class:`~bayescal.reports.page.Page` of :func:`bayescal.reports.review.render_review`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.inference.parameters import label_angle
from bayescal.inference.results import ElastostaticResults
from bayescal.reference import read_paper_reference
from bayescal.reports.figures import plot_pairs
from bayescal.numbers import fixed, table_texts
from bayescal.reports.page import Page

__all__ = ["DISPLAY_UNITS"]

DISPLAY_UNITS = {"urad/(N m)": "μrad/(N·m)"}
"""How the figures write the units the posterior files store in ASCII."""


@dataclass(frozen=True)
class _Facts:
    """The summaries of the elastostatic results that several sections show, computed once (each is an ESS pass)."""

    summary: pd.DataFrame
    parameters: dict
    diagnostics: dict

    @classmethod
    def of(cls, results: ElastostaticResults) -> _Facts:
        return cls(summary=results.summary(), parameters=results.parameters(), diagnostics=results.diagnostics())


def _unit(unit: str) -> str:
    return DISPLAY_UNITS.get(unit, unit)


def _as_published(value: float) -> str:
    """A published value with the digits its table gives (stored as read), none added."""
    return f"{value:g}" if math.isfinite(value) else "–"


def _published_iv(cell: Cell | None) -> dict[str, tuple[float, float]] | None:
    """``{parameter: (value, ±3σ half-width)}`` of the cell's published Table IV, or None when it names none."""
    if cell is None or cell.reference is None:
        return None
    rows = read_paper_reference(cell.reference)
    rows = rows[rows["table"] == "IV"]
    return {str(name): (float(row["value"]), float(row["ci3"])) for name, row in rows.iterrows()}


def _parameter_section(page: Page, results: ElastostaticResults, facts: _Facts, table_iv: dict | None) -> None:
    page.heading("parameters", "Elastostatic parameters" + (" beside Table IV" if table_iv is not None else ""))
    summary, parameters = facts.summary, facts.parameters
    rows = {}
    for name, value in parameters.items():
        row = {"mean": math.nan, "±3σ": math.nan, "±3σ [% of mean]": math.nan}
        if table_iv is not None:
            paper = table_iv.get(name, (math.nan, math.nan))
            row |= {"Table IV": paper[0], "Table IV ±3σ": paper[1], "Table IV ±3σ [%]": 100 * paper[1] / paper[0] if paper[0] else math.nan}
        row |= {"R-hat": math.nan, "unit": _unit(results.parameter_units[name])}
        if "mean" in value:
            row |= {"mean": value["mean"], "±3σ": value["hi3"] - value["mean"], "R-hat": summary.loc[name, "r_hat"]}
            row["±3σ [% of mean]"] = 100 * (value["hi3"] - value["mean"]) / abs(value["mean"])
        # A compliance or a spring stiffness cannot be negative: an interval reaching below 0 says so rather than print it.
        crosses = "mean" in value and value["lo3"] < 0
        row["lower end"] = "cut at 0: cannot be negative, the data do not bound it from below" if crosses else ""
        row["identifiable"] = "mean" in value
        rows[name] = row
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame.index.name = "parameter"
    page.table(
        "parameters",
        frame,
        shown=table_texts(
            frame,
            {"mean": "±3σ", "±3σ": "±3σ"},
            {"±3σ [% of mean]": fixed(1), "R-hat": fixed(3)}
            | ({"Table IV": _as_published, "Table IV ±3σ": _as_published, "Table IV ±3σ [%]": fixed(1)} if table_iv is not None else {}),
        ),
        caption=(
            f"k1..k6 in μrad/(N·m) (k2 without the compensator), {_law_units(results)}; "
            if table_iv is not None
            else f"k1..k{results.closed_form.compliances.size} in the unit of their row"
            + ("; " if results.joint is None else f" (k{results.joint + 1} without the compensator), {_law_units(results)}; ")
        )
        + "each mean rounded to two digits of its ±3σ; not identifiable parameters have no estimate (see the next section)",
    )
    per_angle = summary.loc[[name for name in summary.index if label_angle(name) is not None]]
    if not per_angle.empty:
        frame = pd.DataFrame(
            {
                "mean": per_angle["mean"].to_numpy(),
                "±3σ": 3 * per_angle["sd"].to_numpy(),
                "±3σ [% of mean]": 300 * (per_angle["sd"] / per_angle["mean"].abs()).to_numpy(),
            },
            index=pd.Index([f"{round(label_angle(name), 1) + 0.0:.1f}" for name in per_angle.index], name=f"q{results.joint + 1} [deg]"),
        )
        page.table(
            "k2_per_angle",
            frame,
            shown=table_texts(frame, {"mean": "±3σ", "±3σ": "±3σ"}, {"±3σ [% of mean]": fixed(1)}),
            caption=f"Equivalent joint-{results.joint + 1} compliance (with the compensator) at each campaign angle, μrad/(N·m)",
        )
    page.close()


def _identifiability_section(page: Page, results: ElastostaticResults, facts: _Facts) -> None:
    page.heading("identifiability", "What the data cannot identify, and why")
    ident = results.identifiability
    page.paragraph(
        "The campaign's design (eq 30, one column per joint compliance"
        + ("" if results.joint is None else f", joint {results.joint + 1} one per q{results.joint + 1} angle")
        + f") has rank {ident.rank} of {ident.identifiable.size}: it measures {ident.rank} independent combinations of the "
        f"{ident.identifiable.size} compliances. Its condition number, {ident.condition_number:.3g} with each column scaled to unit "
        "length, says how nearly the columns repeat each other (above 10⁴: ill-conditioned)."
    )
    reasons = {name: reason for name, reason in ident.not_identifiable.items() if label_angle(name) is None}
    page.record("rank", ident.rank)
    page.record("condition_number", ident.condition_number)
    if reasons:
        kind = {name: "from these data" if name in ident.practical else "structural" for name in reasons}
        frame = pd.DataFrame({"kind": kind, "reason": reasons})
        frame.index.name = "parameter"
        page.table("not_identifiable", frame)
        weak = [name for name in ident.practical if name in facts.summary.index]
        if weak:
            _weak_table(page, facts.summary.loc[weak])
    else:
        page.paragraph("Every parameter of the model is identified by this campaign.")
    page.close()


def _weak_table(page: Page, summary: pd.DataFrame) -> None:
    """The posterior of the weakly determined parameters, a lower end below 0 cut at 0 with the reason."""
    frame = pd.DataFrame(
        {"mean": summary["mean"], "±3σ": 3 * summary["sd"], "lower end": summary["lo3"], "upper end": summary["hi3"]},
        index=pd.Index(summary.index, name="parameter"),
    )
    shown = table_texts(frame, {"mean": "±3σ", "±3σ": "±3σ", "lower end": "±3σ", "upper end": "±3σ"})
    below = frame["lower end"] < 0
    # A spring stiffness, a free length or a compliance below 0 is no physical value: shown as 0, with the reason.
    shown.loc[below, "lower end"] = "0 (cut: cannot be negative)"
    frame["unit"] = shown["unit"] = [_unit(u) for u in summary["unit"]]
    page.table(
        "weakly_determined",
        frame,
        shown=shown,
        caption="Their posterior, kept for inspection only: it mostly reflects the prior"
        + ("; a ±3σ interval reaching below 0 is cut at 0, since these quantities cannot be negative" if below.any() else ""),
    )


def _law_units(results: ElastostaticResults) -> str:
    """``K_c in N/mm, s0 in mm``: the compensator law's parameters and their edge units."""
    return ", ".join(f"{name} in {results.registry[name].unit}" for name in results.registry.law_names)


def _pairs_section(page: Page, results: ElastostaticResults, seed: int, table_iv: dict | None) -> None:
    tree = results.tree["posterior"]
    names = [name for name in (*results.registry.law_names, "k2", "k3") if name in tree]
    if len(names) < 2:
        return
    page.heading("pairs", "Posterior pairs")
    compared = table_iv is not None
    table_iv = table_iv or {}
    labels = {name: f"{name} [{_unit(results.parameter_units[name])}]" for name in names}
    draws = {labels[name]: np.asarray(tree[name].values).ravel() for name in names}
    reference = {labels[n]: table_iv[n][0] for n in names if n in table_iv}
    page.record("correlation", pd.DataFrame(draws).corr().to_dict())
    page.figure(
        "pairs_elastostatic",
        plot_pairs(draws, reference=reference, reference_label="Table IV", seed=seed),
        f"Pairs of {', '.join(results.registry.law_names)}, k2 (joint 2 without compensator) and k3, with their correlation ρ; "
        "dashed: Table IV."
        if compared
        else f"Pairs of {', '.join(names)}"
        + ("" if results.joint is None else f" (k{results.joint + 1} without its compensator)")
        + ", with their correlation ρ.",
    )
    page.close()
