"""A plan's document (:class:`~bayescal.summary.Summary`): what ``bayescal plan`` prints for a plan designed or assessed.

:func:`plan_document` lays out the plan's JSON (:meth:`~bayescal.design.plan_design.PlanDesign.to_json` or
:meth:`~bayescal.design.plan_design.PlanEvaluation.to_json`) and its table of predicted widths (their ``summary()``):
the file written, the error predicted at the test pose (ρ0, eq 38), each parameter's predicted ±3σ rounded as
``bayescal calibrate`` rounds it, what the plan cannot bound, and the configurations the cell cannot measure.
:func:`discrimination_document` lays out a plan that separates two candidates of the critique.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from bayescal.summary import Column, Paragraph, Section, Summary, Table

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["plan_document", "discrimination_document"]

HANGING_ONLY_NOTE = ("This cell hangs masses only ([load] directions = \"down\"): no plan of it turns the vertical A1, so k1 keeps "
                     "the cell's value; a cell that pushes or pulls sideways (directions = \"any\", docs/design.md) identifies it.")
"""Said once, where a plan is made: the later commands record it in k1's reason without a warning."""


def _criterion(payload: dict) -> list[Paragraph]:
    """The error predicted at the test pose, everything counted, and the part the plan's data alone leave."""
    from bayescal.numbers import error_length

    criterion = payload["criterion"]
    if criterion is None:
        return [Paragraph("predicted rms error left at the test pose after compensation (ρ0, eq 38): not predictable")]
    lines = [Paragraph("predicted rms error left at the test pose after compensation (ρ0, eq 38, linearised at the design), "
                       f"everything counted: {error_length(criterion)}")]
    if payload["criterion_prior_share_of_mean_square"] > 0:
        lines.append(Paragraph(
            f"from the plan's data alone {error_length(payload['criterion_identified_only'])}; the rest "
            f"({payload['criterion_prior_share_of_mean_square']:.0%} of the mean square) from "
            f"{payload['criterion_includes'].split('the prior of ', 1)[1]}, its prior in the cell ([joints] k_log_sd)",
            wrap=True, indent="  ", subsequent_indent="  "))
    return lines


def _width_table(table: list[tuple[str, dict]]) -> Table:
    """Each parameter's value, predicted ±3σ (two digits) and width (3 sd / value), and Table IV's width when known."""
    from bayescal.numbers import rounded_pair

    published = _published(table)
    columns = (Column("parameter", width=10, align="<"), Column("unit", width=12, align="<"), Column("value", width=8),
               Column("±3σ", width=13), Column("width", "%", width=9)) + ((Column("Table IV", "%", width=10),) if published else ())
    rows, values = [], []
    for name, row in table:
        _, half = rounded_pair(row["value"], 3 * row["sd"])
        cells = (str(name), row["unit"], f"{row['value']:g}", half if half != "–" else "not excited",
                 f"{row['width_3sd_pct']:.1f}%" if math.isfinite(row["width_3sd_pct"]) else "")
        value = {"parameter": name, "unit": row["unit"], "value": row["value"], "±3σ": 3 * row["sd"], "width": row["width_3sd_pct"]}
        if published:
            cells += (f"{row['table_iv_pct']:.1f}%" if math.isfinite(row["table_iv_pct"]) else "–",)
            value["Table IV"] = row["table_iv_pct"]
        rows.append(cells)
        values.append(value)
    return Table("parameters", columns, tuple(rows), tuple(values))


def _published(table: list[tuple[str, dict]]) -> bool:
    """Whether the rows of ``table`` carry Table IV's widths."""
    return bool(table) and "table_iv_pct" in table[0][1]


def plan_document(payload: dict, table: list[tuple[str, dict]], hanging_only: bool) -> Summary:
    """The plan of ``payload`` (its JSON, with ``output`` when it was written) and ``table`` (its prediction's
    :meth:`~bayescal.design.prediction.PlanPrediction.rows`, the rows of its ``summary()``) as one document.

    ``hanging_only``: whether the cell's end-effector hangs masses only, which no plan can make identify k1.
    """
    head = _criterion(payload)
    if "output" in payload:
        loads = f", forces of {payload['force_max_N']:.0f} N in directions of the design" if "force_max_N" in payload else ""
        angles = ", ".join(f"{v:.1f}" for v in payload["q2_deg"])
        title = f"wrote {payload['output']}: {payload['configurations']} configurations at q2 = {angles} deg{loads}"
    else:
        title, head = head[0].text, head[1:]
    blocks = [_width_table(table), Paragraph("±3σ: the predicted 3 sd after measuring the plan, rounded to two digits; width: 3 sd / value"
                                             + (" (Table IV: Klimchik et al.)" if _published(table) else ""), kind="note")]
    unbounded = [name for name, row in table if row["value"] - 3 * row["sd"] < 0]
    if unbounded:
        blocks.append(Paragraph(f"{', '.join(unbounded)}: the predicted interval reaches below 0, which they cannot; this plan does not bound them.",
                                kind="warning"))
    blocks += [Paragraph(f"configuration {v['config']}: {v['reason']}", kind="warning") for v in payload.get("violations", [])]
    sections = [Section(tuple(blocks))] + ([Section((Paragraph(HANGING_ONLY_NOTE, wrap=True),))] if hanging_only else [])
    return Summary(title, tuple(head), tuple(sections))


def _configuration_table(table: pd.DataFrame) -> Table:
    """One row per configuration, its angles (deg) and load (kg) to 0.1 as a person sets them on the robot, laid out as
    pandas prints a table of texts (each column one space wider than its longest text, one space apart)."""
    from bayescal.numbers import fixed, table_texts

    texts = table_texts(table, {}, {column: fixed(1) for column in table.columns})
    index = [str(i) for i in texts.index]
    columns = (Column("configuration", width=max(map(len, index)), align="<", header=""),) + tuple(
        Column(name.rsplit("_", 1)[0], name.rsplit("_", 1)[1], width=max(len(name), 1 + int(texts[name].str.len().max())), before=" ", header=name)
        for name in texts.columns
    )
    rows = tuple((i, *row) for i, row in zip(index, texts.itertuples(index=False)))
    values = tuple({"configuration": int(i)} | {c.name: row[c.header] for c in columns[1:]} for i, row in zip(texts.index, table.to_dict("records")))
    return Table("configurations", columns, rows, values)


def discrimination_document(design, output: str, campaign: str) -> Summary:
    """The plan that separates two candidates (:class:`~bayescal.design.discriminate.DiscriminatingDesign`) as one document:
    the file written, the expected log-likelihood ratio (nats) and its standard errors beside the tied ``campaign``'s,
    the order to measure in, and the configurations."""
    payload = design.to_json()
    a, b = design.planned.between
    planned, tied = design.planned.nats, design.campaign.nats
    title = (f"wrote {output}: {len(design.plan)} configurations at q2 = {', '.join(f'{v:g}' for v in payload['q2_deg'])} deg, "
             f"loads {min(payload['load_kg']):g}-{max(payload['load_kg']):g} kg")
    ratio = Paragraph(
        f"expected log-likelihood ratio of the true model over the other (nats; {campaign} in brackets): "
        f"{planned[0]:.1f} ({tied[0]:.1f}) if {a} is true, {planned[1]:.1f} ({tied[1]:.1f}) if {b} is; "
        f"in standard errors of the held-out comparison {design.planned.z[0]:.1f} ({design.campaign.z[0]:.1f}) "
        f"and {design.planned.z[1]:.1f} ({design.campaign.z[1]:.1f})"
    )
    return Summary(title, (ratio, Paragraph(design.order), _configuration_table(design.summary())))
