"""The elastostatic calibration's document (:class:`~bayescal.summary.Summary`): what ``bayescal calibrate`` prints.

:func:`calibration_document` lays out an :class:`~bayescal.inference.results.ElastostaticResults` with its test
pose's prediction: the parameters beside the published Table IV when the cell names it, what the campaign cannot
identify, joint 2's compliance at each angle, the diagnostics, the error left at the test pose and the next step.
It reads the results and says them; every number was computed by the fit and the prediction.
"""

from __future__ import annotations

import math

from bayescal.summary import Column, Paragraph, Section, Span, Summary, Table

__all__ = ["calibration_document"]


def _parameter_table(results, reference_file) -> tuple[Table, Paragraph]:
    """Each parameter's mean and ±3σ (rounded to two digits of its 3 sd) and width, beside Table IV when compared."""
    import pandas as pd

    from bayescal.reference import beside_published, read_paper_reference, width_3sd_pct
    from bayescal.numbers import rounded_pair

    parameters = results.parameters()
    estimates = pd.DataFrame(
        {name: (entry.get("mean", math.nan), entry.get("sd", math.nan)) for name, entry in parameters.items()}, index=["mean", "sd"]
    ).T
    # Only a cell that names published results of its own robot is compared with them.
    compared = reference_file is not None
    if compared:
        paper = beside_published(estimates, "IV", read_paper_reference(reference_file))
    else:
        paper = estimates.assign(half_width_3sd=3 * estimates["sd"], width_3sd_pct=width_3sd_pct(estimates["mean"], estimates["sd"]))
    columns = (Column("parameter", width=10, align="<"), Column("unit", width=12, align="<"), Column("mean", width=10),
               Column("±3σ", width=10), Column("width", "%", width=8))
    if compared:
        columns += (Column("Table IV", width=9, before="   | "), Column("Table IV ±3σ", width=8, header="±3σ"),
                    Column("Table IV width", "%", width=8, header="width"))
    rows, values = [], []
    for name, row in paper.iterrows():
        unit = results.parameter_units[name]
        if "mean" in parameters[name]:
            mean, half = rounded_pair(row["mean"], row["half_width_3sd"])
            cells = (name, unit, mean, half, f"{row['width_3sd_pct']:.1f}%")
        else:
            cells = (name, unit, Span("not identifiable", 3))
        value = {"parameter": name, "unit": unit, "mean": row["mean"], "±3σ": row["half_width_3sd"], "width": row["width_3sd_pct"]}
        if compared:
            published = (f"{row['published']:.4g}", f"{row['published_half_width_3sd']:.3g}", f"{row['published_width_pct']:.1f}%")
            cells += published if math.isfinite(row["published"]) else ("–",)
            value |= {"Table IV": row["published"], "Table IV ±3σ": row["published_half_width_3sd"], "Table IV width": row["published_width_pct"]}
        rows.append(cells)
        values.append(value)
    note = Paragraph("Intervals are mean ± 3 sd, rounded to two digits of the 3 sd; widths 3 sd / |mean|"
                     + (" (Table IV: Klimchik et al.)." if compared else "."), kind="note")
    return Table("parameters", columns, tuple(rows), tuple(values)), note


def _identifiability_section(results, reasons: dict[str, str]) -> list[Section]:
    """Why each parameter the campaign cannot identify is not, grouped by reason; none when all are identified."""
    from bayescal.inference.identifiability import grouped

    if not reasons:
        return []
    blocks = [Paragraph(f"{', '.join(names)}: {reason}.", wrap=True, indent="  ", subsequent_indent="    ") for names, reason in grouped(reasons)]
    weak = results.weakly_determined()
    if weak:
        blocks.append(Paragraph(f"The posterior of {', '.join(weak)} is kept in the DataTree and in the JSON's weakly_determined block.", indent="  "))
    return [Section(tuple(blocks), heading="Not identifiable:")]


def _per_angle_section(results) -> list[Section]:
    """The compensated joint's compliance at each campaign angle (±3σ), the paper's Fig. 7; none without a compensator."""
    from bayescal.numbers import with_uncertainty

    j = -1 if results.joint is None else results.joint + 1
    lines = [
        Paragraph(f"q{j} = {angle:>8.2f} deg  {with_uncertainty(entry['mean'], entry['hi3'] - entry['mean'], 'urad/(N m)')}", indent="  ")
        for angle, entry in results.per_angle().items()
        if "mean" in entry
    ]
    return [Section(tuple(lines), heading=f"Joint {j} with its compensator at each campaign angle (±3σ; the paper's Fig. 7):")] if lines else []


def _closing_sections(results, test_pose, reasons: dict[str, str]) -> list[Section]:
    """Diagnostics and the test pose (errors in μm, deflections in mm), then what to do next."""
    from bayescal.inference.equations import HANGING_ONLY_REASON
    from bayescal.inference.next_steps import calibration_next_steps
    from bayescal.numbers import error_um
    from bayescal.sampling.summary import ESS_LIMIT, R_HAT_LIMIT, converged

    d = results.diagnostics()
    lines = [
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f}, "
        f"residual rms {error_um(d['residual_rms_mm'])}" + (f", χ²/dof {d['chi2_per_dof']:.2f}" if d["chi2_per_dof"] is not None else ""),
        f"identifiability: rank {results.identifiability.rank} of {len(results.identifiability.names)}, "
        f"condition number {results.identifiability.condition_number:.3g} (unit columns)",
        f"(wanted: R-hat ≤ {R_HAT_LIMIT}, both ESS ≥ {ESS_LIMIT}; χ²/dof near 1: residuals as large as the tracker's noise; "
        "rank below the columns: some compliances not identifiable; docs/glossary.md)",
    ]
    block = test_pose.to_json()
    q9973 = None
    if block.get("available", True):
        q9973 = block["residual_error_mm"]["q99.73"]
        lines += test_pose.lines()
    else:
        lines.append(f"test pose: not predicted: {block['reason']}")
    limited = [name for name, reason in reasons.items() if reason.endswith(HANGING_ONLY_REASON)]
    advice = calibration_next_steps(d, sorted(reasons), q9973, converged(d), limited)
    return [Section(tuple(Paragraph(line) for line in lines)), Section((Paragraph(advice, wrap=True),))]


def calibration_document(results, test_pose, source: str, seed: int, reference_file=None) -> Summary:
    """The calibration of ``results`` as one document.

    Parameters
    ----------
    results : ElastostaticResults
    test_pose : TestPosePrediction
        The cell's test pose predicted from ``results`` (:func:`~bayescal.compensation.testpose.predict_cell_test_pose`).
    source : str
        The campaign's name, for the title.
    seed : int
        The seed the fit was drawn with, for the title.
    reference_file : path, optional
        The published results the cell names (its ``reference``); the parameters are set beside Table IV when given.
    """
    table, note = _parameter_table(results, reference_file)
    reasons = {k: v for k, v in results.identifiability.not_identifiable.items() if k in results.parameter_units}
    title = (f"{source}: {results.n_equations} equations ({results.n_rows} rows x 3 coordinates), "
             f"{results.model} model, {results.sampler_name}, seed {seed}")
    sections = [Section((table, note)), *_identifiability_section(results, reasons), *_per_angle_section(results),
                *_closing_sections(results, test_pose, reasons)]
    return Summary(title, (), tuple(sections))
