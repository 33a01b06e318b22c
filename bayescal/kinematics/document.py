"""A kinematic calibration's document (:class:`~bayescal.summary.Summary`): what ``bayescal kinematics`` prints.

:func:`kinematic_document` lays out a :class:`~bayescal.kinematics.results.KinematicResults` or an
:class:`~bayescal.kinematics.elastic.ElasticKinematicResults`: the rung and its size, the in-sample error, the model
error learned, the refined spring when there is one, the identified parameters and what the data leave unidentified.
"""

from __future__ import annotations

from bayescal.summary import Column, Paragraph, Summary, Table

__all__ = ["kinematic_document", "HIDDEN_SHOWN"]

HIDDEN_SHOWN = 8
"""Unidentifiable parameters named one by one in the document; the rest are counted (the JSON lists them all)."""


def _parameter_table(table) -> Table:
    """Each identified parameter's posterior mean and sd beside its prior sd, in its own unit."""
    columns = (Column("parameter", width=34, align="<"), Column("unit", width=12), Column("mean", width=12), Column("sd", width=10),
               Column("prior sd", width=10))
    shown = table[table["identified"]]
    rows = tuple((str(name), row["unit"], f"{row['mean']:.4g}", f"{row['sd']:.3g}", f"{row['prior_sd']:.3g}") for name, row in shown.iterrows())
    values = tuple({"parameter": name, "unit": row["unit"], "mean": row["mean"], "sd": row["sd"], "prior sd": row["prior_sd"]}
                   for name, row in shown.iterrows())
    return Table("parameters", columns, rows, values)


def kinematic_document(results) -> Summary:
    """The calibration of ``results`` as one document (every number from its ``diagnostics()``, ``summary()`` and
    ``identifiability()``)."""
    d = results.diagnostics()
    table = results.summary()
    blocks: list[Paragraph | Table] = [
        Paragraph(f"residual error per marker: mean {d['error_mean_mm']:.2f} mm, sd {d['error_sd_mm']:.2f}, max {d['error_max_mm']:.2f} "
                  "(in sample; `bayescal critique` scores it held out)"),
        Paragraph(f"model error learned from the data: {d['model_error_sd_mm']:.3f} mm per coordinate, on top of the tracker's noise"),
    ]
    if "K_c_N_per_mm" in d:
        blocks.append(Paragraph(f"the spring, refined from the elastostatic calibration's: K_c = {d['K_c_N_per_mm'][0]:.1f} ± "
                                f"{d['K_c_N_per_mm'][1]:.1f} N/mm, s0 = {d['s0_mm'][0]:.1f} ± {d['s0_mm'][1]:.1f} mm"))
    blocks.append(_parameter_table(table))
    hidden = results.identifiability()
    if hidden:
        blocks.append(Paragraph(f"{len(hidden)} parameters not identifiable by these data (they keep their prior; see --json):", kind="warning"))
        blocks += [Paragraph(f"{entry['parameter']}: {entry['why']}", indent="  ") for entry in hidden[:HIDDEN_SHOWN]]
        if len(hidden) > HIDDEN_SHOWN:
            blocks.append(Paragraph(f"… and {len(hidden) - HIDDEN_SHOWN} more", indent="  "))
    partly = int((~table["identified"]).sum()) - len(hidden)
    if partly:
        blocks.append(Paragraph(f"{partly} more parameters are partly identified (posterior sd 0.5-0.9 of the prior's): see --json"))
    title = (f"model '{d['rung']}', {d['parameters']} parameters ({d['identified']} identified by the data), "
             f"{d['configurations']} configurations")
    return Summary(title, tuple(blocks))
