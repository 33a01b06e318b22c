"""The compensator geometry's document (:class:`~bayescal.summary.Summary`): what ``bayescal geometry`` prints.

:func:`geometry_document` lays out a :class:`~bayescal.geometry.posterior.GeometryPosterior`: every posterior
variable with its closed-form value and, when the published results are given, Table II beside it, then the
convergence, the residuals and the arc's sense.  :func:`beside_table_ii` is the one comparison with Table II that
the document and the command's JSON both show.
"""

from __future__ import annotations

import pandas as pd

from bayescal.summary import Column, Paragraph, Section, Summary, Table
from bayescal.units import MM

__all__ = ["beside_table_ii", "geometry_document", "TABLE_II_ROWS"]

TABLE_II_ROWS = ("L", "a_x", "a_y")
"""The posterior variables Table II publishes."""


def beside_table_ii(summary: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``summary`` (the results' ``summary()``) that Table II publishes, beside its values and ±3σ (mm)."""
    from bayescal.reference import beside_published

    paper = beside_published(summary.loc[[name for name in TABLE_II_ROWS if name in summary.index], ["mean", "sd"]], "II", reference)
    return paper[paper["published"].notna()]


def _parameter_table(result, summary: pd.DataFrame, paper: pd.DataFrame | None) -> Table:
    """Every posterior variable to the decimal of its sd's second significant digit, its closed form, and Table II."""
    from bayescal.numbers import decimals_of, fixed, rounded_pair

    closed_table = result.closed_form.summary()
    columns = (Column("parameter", width=16, align="<"), Column("unit", width=5, align="<"), Column("mean", width=11),
               Column("sd", width=9), Column("mean-3sd", width=11), Column("mean+3sd", width=11), Column("r_hat", width=7),
               Column("closed form", width=13), Column("Table II", width=10), Column("±3σ", width=7))
    rows, values = [], []
    for name, row in summary.iterrows():
        # Every number of a row to the decimal of the second significant digit of its sd (bayescal.numbers).
        shown = fixed(decimals_of(row["sd"]))
        closed = closed_table.loc[name, "value"] if name in closed_table.index else None
        mean, sd = rounded_pair(row["mean"], row["sd"])
        cells = (str(name), row["unit"], mean, sd, shown(row["lo3"]), shown(row["hi3"]), f"{row['r_hat']:.3f}", "" if closed is None else shown(closed))
        value = {"parameter": name, "unit": row["unit"], "mean": row["mean"], "sd": row["sd"], "mean-3sd": row["lo3"], "mean+3sd": row["hi3"],
                 "r_hat": row["r_hat"], "closed form": closed}
        if paper is not None and name in paper.index:
            # As Table II prints them: two decimals, which is all its half-widths give.
            cells += (f"{paper.loc[name, 'published']:.2f}", f"{paper.loc[name, 'published_half_width_3sd']:.2f}")
            value |= {"Table II": paper.loc[name, "published"], "±3σ": paper.loc[name, "published_half_width_3sd"]}
        rows.append(cells)
        values.append(value)
    return Table("parameters", columns, tuple(rows), tuple(values), rule=True)


def geometry_document(result, source: str, seed: int, reference: pd.DataFrame | None = None, saved_to: str | None = None) -> Summary:
    """The geometry of ``result`` as one document.

    Parameters
    ----------
    result : GeometryPosterior
    source : str
        The points file's name, for the title.
    seed : int
        The seed the posterior was drawn with, for the title.
    reference : pandas.DataFrame, optional
        The published results (:func:`~bayescal.reference.read_paper_reference`): Table II beside the posterior when given.
    saved_to : str, optional
        Where the posterior was written, said at the end when given.
    """
    summary = result.summary()
    paper = None if reference is None else beside_table_ii(summary, reference)
    d = result.diagnostics()
    rms = ", ".join(f"{name} {value / MM:.3f}" for name, value in result.residuals_rms.items())
    sense = result.closed_form.lever
    lines = [
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f} "
        f"({d['n_chains']} chains x {d['n_draws']} draws)",
        f"residual rms at the posterior mean [mm]: {rms}",
        f"P1 arc: {'clockwise' if sense.sense < 0 else 'counter-clockwise'} in (x, y) as q2 increases "
        f"(the best orthogonal R of eq 19 is a {'reflection' if sense.sense < 0 else 'rotation'})",
        *(["Table II: Klimchik et al., published value and ±3σ half-width"] if paper is not None else []),
        *([f"posterior saved to {saved_to}"] if saved_to else []),
    ]
    return Summary(
        f"Compensator geometry from {source} ({result.cylinder_model} cylinder markers, seed {seed})",
        (),
        (Section((_parameter_table(result, summary, paper),)), Section(tuple(Paragraph(line) for line in lines))),
    )
