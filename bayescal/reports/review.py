"""The calibration review: one page to read, trust and pass on.

:func:`render_review` turns what a calibration produced (the geometry posterior,
the elastostatic results restored from their posterior, the residual table, the
test-pose prediction and, when they were run, a plan, a q2-angle study and a
critique) into the files of a report folder: ``index.html`` with its figures
as PNG files beside it, ``summary.md`` (the same tables and figures in
Markdown) and ``numbers.json`` (every number the page shows, by section).  It
renders what it is given and computes nothing a library function does not;
sections appear only for what was run.  The plan, study and critique files
are shown as they come: known keys in their own tables, any other key in a
generic one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.inference.parameters import GEOMETRY_PARAMETERS
from bayescal.inference.results import ElastostaticResults
from bayescal.compensation.testpose import TestPosePrediction
from bayescal.reference import beside_published
from bayescal.reports.compensation import compensation_section
from bayescal.numbers import error_length, fixed, table_texts
from bayescal.compensation.test_pose_text import unidentified_sentence
from bayescal.reports.page import HTML_FILE, JSON_FILE, MARKDOWN_FILE, Page
from bayescal.reports.review_data import data_section, residual_section
from bayescal.kinematics.ladder import LadderFindings
from bayescal.reports.ladder import ladder_section
from bayescal.reports.review_files import critique_section, plan_section, registration_section
from bayescal.reports.review_parameters import (
    _as_published,
    _Facts,
    _identifiability_section,
    _pairs_section,
    _parameter_section,
    _published_iv,
    _unit,
)
from bayescal.reports.figures import plot_error_distribution, plot_pairs, plot_rank
from bayescal.reports.plots import plot_eta_curves, plot_joint2_compliance
from bayescal.robot.compensator import Compensator, CompensatorGeometry
from bayescal.sampling.summary import ESS_LIMIT, R_HAT_LIMIT, diagnostics, summarize
from bayescal.inference.compliance_band import equivalent_compliance_band
from bayescal.units import DEG, MM, UM, URAD_PER_NM

if TYPE_CHECKING:
    # Read at run time from their files by the CLI; the review only reads their attributes.
    from bayescal.critique.results import CritiqueFindings
    from bayescal.design.plan_design import PlanFindings
    from bayescal.registration.register import RegistrationFindings

__all__ = ["ReviewInputs", "render_review", "HTML_FILE", "MARKDOWN_FILE", "JSON_FILE"]

ETA_S0_MM = (300.0, 400.0, 500.0, 600.0)
"""Spring free lengths (mm) of the η(q2) curves beside the identified one, spanning the paper's Fig. 3."""
GEOMETRY_NAMES = tuple(parameter.name for parameter in GEOMETRY_PARAMETERS)
"""The compensator geometry of Table II (and the lever angle phi, which it does not list)."""


@dataclass
class ReviewInputs:
    """What a review shows; every field but ``sources`` may be missing, and its section is then left out.

    Attributes
    ----------
    sources : dict
        What each input file is (e.g. ``"calibration posterior"``) and its path, listed at the top.
    geometry : xarray.DataTree or None
        The geometry posterior (``bayescal geometry --posterior``).
    results : ElastostaticResults or None
        The elastostatic identification (:func:`~bayescal.inference.elastostatic.restore_results`).
    campaign, cell
        The campaign and the cell of ``results`` (required with it).
    residuals : pandas.DataFrame or None
        :func:`~bayescal.inference.residuals.residual_table` of ``results``.
    test_pose : TestPosePrediction or None
        The prediction at the cell's test pose.
    plan : PlanFindings or None
        The JSON printed by ``bayescal plan --json`` (:meth:`PlanFindings.load`).
    critique : CritiqueFindings or None
        The JSON printed by ``bayescal critique --json`` of a campaign (:meth:`CritiqueFindings.load`).
    ladder : LadderFindings or None
        The model ladder of a cell of measured points (``bayescal critique POSITIONS.csv --json``, :meth:`LadderFindings.load`).
    study : pandas.DataFrame or None
        A q2-angle study table.
    compensation : pandas.DataFrame or None
        A compensated program (:func:`~bayescal.reports.compensation.read_compensated`).
    registration : RegistrationFindings or None
        The registration file written by ``bayescal axes -o`` (:meth:`RegistrationFindings.load`).
    seed : int
        Seed of the choice of draws shown in the pair plots.
    """

    sources: dict[str, str] = field(default_factory=dict)
    geometry: Any = None
    results: ElastostaticResults | None = None
    campaign: Campaign | None = None
    cell: Cell | None = None
    residuals: pd.DataFrame | None = None
    test_pose: TestPosePrediction | None = None
    plan: PlanFindings | None = None
    critique: CritiqueFindings | None = None
    ladder: LadderFindings | None = None
    study: pd.DataFrame | None = None
    compensation: pd.DataFrame | None = None
    registration: RegistrationFindings | None = None
    seed: int = 0


def render_review(inputs: ReviewInputs) -> dict[str, bytes]:
    """The files of the report folder: name to content.

    Returns
    -------
    dict
        :data:`HTML_FILE`, :data:`MARKDOWN_FILE`, :data:`JSON_FILE` and one PNG per figure.
    """
    if inputs.results is not None and (inputs.campaign is None or inputs.cell is None):
        raise ValueError("a review of elastostatic results needs their campaign and cell")
    page = Page("Calibration review")
    facts = _Facts.of(inputs.results) if inputs.results is not None else None
    _overview(page, inputs, facts)
    # Results first, for the reader who stops after the first screen; then what they rest on.
    if inputs.results is not None:
        _parameter_section(page, inputs.results, facts, _published_iv(inputs.cell))
        _identifiability_section(page, inputs.results, facts)
    if inputs.test_pose is not None:
        _test_pose_section(page, inputs.test_pose, inputs.cell)
    if inputs.compensation is not None:
        compensation_section(page, inputs.compensation, inputs.sources.get("compensated program", ""))
    if inputs.geometry is not None:
        _geometry_section(page, inputs.geometry, inputs.seed)
    if inputs.registration is not None:
        registration_section(page, inputs.registration, inputs.sources.get("registration", ""))
    if inputs.results is not None:
        _compensator_section(page, inputs.results, inputs.cell)
        data_section(page, inputs.results, inputs.campaign, inputs.cell)
        if inputs.residuals is not None:
            residual_section(page, inputs.results, inputs.residuals, inputs.campaign, inputs.cell)
    if inputs.critique is not None:
        critique_section(page, inputs.critique, inputs.sources.get("critique", ""))
    if inputs.ladder is not None:
        ladder_section(page, inputs.ladder, inputs.sources.get("critique", ""))
    _convergence_section(page, inputs, facts)
    if inputs.results is not None:
        _pairs_section(page, inputs.results, inputs.seed, _published_iv(inputs.cell))
    if inputs.plan is not None:
        plan_section(page, inputs.plan, inputs.sources.get("plan", ""))
    if inputs.study is not None:
        _study_section(page, inputs.study, inputs.sources.get("q2-angle study", ""))
    page.glossary()
    return page.files()


# ---------------------------------------------------------------------------- sections
def _overview(page: Page, inputs: ReviewInputs, facts: _Facts | None) -> None:
    page.heading("overview", "Overview")
    lines = []
    results = inputs.results
    if results is not None:
        parameters = facts.parameters
        known = [name for name, value in parameters.items() if "mean" in value]
        unknown = [name for name, value in parameters.items() if "mean" not in value]
        lines.append(f"Identified from the campaign: {', '.join(known) or 'nothing'}; not identifiable: {', '.join(unknown) or 'none'}.")
        page.record("identified", known)
        page.record("not_identifiable", unknown)
        report = facts.diagnostics
        page.record("elastostatic_diagnostics", {key: report[key] for key in ("r_hat_max", "ess_bulk_min", "ess_tail_min", "chi2_per_dof")})
        converged = report["r_hat_max"] <= R_HAT_LIMIT and min(report["ess_bulk_min"], report["ess_tail_min"]) >= ESS_LIMIT
        lines.append(
            f"Elastostatic posterior: R-hat ≤ {report['r_hat_max']:.3f}, bulk ESS ≥ {report['ess_bulk_min']:.0f}, "
            f"tail ESS ≥ {report['ess_tail_min']:.0f} ({'converged' if converged else f'NOT converged by the thresholds '
            f'R-hat ≤ {R_HAT_LIMIT}, bulk and tail ESS ≥ {ESS_LIMIT}'}; the words are explained at the end of the page)."
        )
        if report["chi2_per_dof"] is not None:
            lines.append(f"Fit against the tracker's noise model: χ²/dof = {report['chi2_per_dof']:.3f} (1 when the model describes the data).")
    if inputs.test_pose is not None and inputs.test_pose.available:
        error = inputs.test_pose.to_json()["residual_error_mm"]
        page.record("test_pose_error_mm", {"rms": error["rms"], "q99.73": error["q99.73"], "identified_only_q99.73": error["identified_only"]["q99.73"]})
        lines.append(
            f"Positioning error left at the test pose after compensation, everything counted: rms {error_length(error['rms'])}, "
            f"99.73 % of draws below {error_length(error['q99.73'])}"
            + (f"; from the identified parameters alone {error_length(error['identified_only']['q99.73'])} (99.73 %), the rest from "
               f"{', '.join(error['unidentified'])}, which the campaign does not identify." if error["unidentified"] else ".")
        )
    if inputs.critique is not None:
        lines.append(f"Critique: {str(inputs.critique.verdict).removeprefix('verdict: ')}.")
    if inputs.ladder is not None:
        lines.append(f"Model ladder: {inputs.ladder.verdict.removeprefix('verdict: ')}.")
    page.items(lines or ["No posterior was given: only the files below are shown."])
    page.table("inputs", pd.DataFrame({"file": list(inputs.sources.values())}, index=pd.Index(list(inputs.sources), name="input")))
    page.close()


def _geometry_section(page: Page, tree, seed: int) -> None:
    page.heading("geometry", "Compensator geometry beside Table II")
    observed = tree["observed_data"] if "observed_data" in tree.children else None
    if observed is not None and "q2_deg" in observed:
        q2 = np.asarray(observed["q2_deg"].values, dtype=float)
        page.record("points", {"count": q2.size, "q2_angles": int(np.unique(q2).size), "q2_min_deg": q2.min(), "q2_max_deg": q2.max()})
        page.paragraph(
            f"{q2.size} tracker points at {np.unique(q2).size} q2 angles from {q2.min():g} to {q2.max():g} deg "
            f"({tree.attrs.get('source', 'source not recorded')}); model: {tree.attrs.get('model', 'not recorded')}."
        )
    names = [name for name in GEOMETRY_NAMES if name in tree["posterior"]]
    summary = summarize(tree, names)
    paper = beside_published(summary[["mean", "sd"]], "II")
    frame = pd.DataFrame(
        {
            "mean": summary["mean"],
            "±3σ": paper["half_width_3sd"],
            "Table II": paper["published"],
            "Table II ±3σ": paper["published_half_width_3sd"],
            "difference in posterior sd": paper["difference_in_sd"],
            "R-hat": summary["r_hat"],
            "bulk ESS": summary["ess_bulk"],
            "unit": [_unit(u) for u in summary["unit"]],
        },
        index=pd.Index(names, name="parameter"),
    )
    page.table(
        "parameters",
        frame,
        shown=table_texts(
            frame,
            {"mean": "±3σ", "±3σ": "±3σ"},
            {"Table II": _as_published, "Table II ±3σ": _as_published, "difference in posterior sd": fixed(1), "R-hat": fixed(3), "bulk ESS": fixed(0)},
        ),
        caption="Posterior mean and ±3σ half-width beside Klimchik et al., Table II; each mean rounded to two digits of its ±3σ",
    )
    draws = {f"{name} [{summary.loc[name, 'unit']}]": np.asarray(tree["posterior"][name].values).ravel() for name in names}
    reference = {f"{n} [{summary.loc[n, 'unit']}]": paper.loc[n, "published"] for n in names if not math.isnan(paper.loc[n, "published"])}
    page.record("correlation", pd.DataFrame(draws).corr().to_dict())
    page.figure("geometry_pairs", plot_pairs(draws, reference=reference, reference_label="Table II", seed=seed), "Geometry posterior: pairs of L, a_x, a_y, phi; dashed: Table II.")
    page.close()


def _convergence_section(page: Page, inputs: ReviewInputs, facts: _Facts | None) -> None:
    posteriors = {}
    if inputs.geometry is not None:
        posteriors["geometry"] = inputs.geometry
    if inputs.results is not None:
        posteriors["elastostatic"] = inputs.results.tree
    if not posteriors:
        return
    page.heading("convergence", "Convergence diagnostics")
    rows = {}
    for name, tree in posteriors.items():
        report = facts.diagnostics if name == "elastostatic" else diagnostics(tree)
        rows[name] = {key: report[key] for key in ("r_hat_max", "ess_bulk_min", "ess_tail_min", "n_chains", "n_draws")}
        rows[name]["sampler"] = str(tree.attrs.get("sampler", "not recorded"))
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame.index.name = "posterior"
    frame = frame.rename(columns={"r_hat_max": "R-hat (largest)", "ess_bulk_min": "bulk ESS (smallest)", "ess_tail_min": "tail ESS (smallest)",
                                  "n_chains": "chains", "n_draws": "draws per chain"})
    page.table(
        "worst",
        frame,
        shown=table_texts(frame, {}, {"R-hat (largest)": fixed(3), "bulk ESS (smallest)": fixed(0), "tail ESS (smallest)": fixed(0)}),
        caption=f"Worst case over all variables; thresholds R-hat ≤ {R_HAT_LIMIT}, bulk and tail ESS ≥ {ESS_LIMIT}",
    )
    if inputs.results is not None:
        tree = inputs.results.tree["posterior"]
        units = inputs.results.parameter_units
        names = [name for name in units if name in tree and name not in inputs.results.identifiability.reasons]
        draws = {f"{name} [{_unit(units[name])}]": np.asarray(tree[name].values) for name in names}
        page.figure("rank_elastostatic", plot_rank(draws), "Rank plots of the elastostatic posterior: flat and overlapping when the chains mix.")
    if inputs.geometry is not None:
        tree = inputs.geometry["posterior"]
        draws = {f"{name} [{tree[name].attrs.get('units', '')}]": np.asarray(tree[name].values) for name in GEOMETRY_NAMES if name in tree}
        page.figure("rank_geometry", plot_rank(draws, columns=4), "Rank plots of the geometry posterior.")
    page.close()


def _compensator_section(page: Page, results: ElastostaticResults, cell: Cell) -> None:
    if cell.compensator is None:
        return
    page.heading("compensator", "The compensator: η(q2) and joint 2's compliance")
    # η of eq 9 is the spring's: another law's compensator has the compliance band alone.
    if isinstance(cell.compensator, Compensator):
        _eta_figure(page, results, cell)
    if results.draws.spring is not None:
        # The cell's compliance and spring are nominal values, not a truth, for measured data.
        band = equivalent_compliance_band(results, cell).drop(columns="truth_urad_per_Nm")
        own = float(np.mean(1.0 / results.draws.spring[..., 0]))
        closed = results.closed_form
        page.figure(
            "joint2_compliance",
            plot_joint2_compliance(band, results.compensated_angles, closed.k2, closed.k2_sd, own=own),
            "Joint 2's equivalent compliance against q2 with its 99.73 % posterior band (the paper's Fig. 7), "
            "and without the compensator (dashed).",
        )
        page.record("joint2_compliance_band", band.reset_index().to_dict(orient="list"))
        page.record("joint2_own_compliance_urad_per_Nm", own / URAD_PER_NM)
    else:
        page.paragraph("The campaign has fewer than three q2 angles: joint 2's compliance is known only at its own angles (table above).")
    page.close()


def _eta_figure(page: Page, results: ElastostaticResults, cell: Cell) -> None:
    """η(q2) of eq 9 for several free lengths of the cell's spring (the paper's Fig. 3)."""
    tree = results.tree["posterior"]
    mean = results.geometry.mean
    if "L" in tree:
        mean = np.array([float(tree[p.name].mean()) * p.si_factor for p in GEOMETRY_PARAMETERS])
    geometry = CompensatorGeometry(*mean)
    s0 = float(tree["s0"].mean()) * MM if "s0" in tree else cell.compensator.s0
    values = sorted({*(v * MM for v in ETA_S0_MM), s0})
    page.record("eta_s0_mm", {"curves": [v / MM for v in values], "highlighted": s0 / MM})
    page.figure(
        "eta",
        plot_eta_curves(geometry, values, highlight=s0),
        f"η(q2) of eq 9 for several spring free lengths (the paper's Fig. 3); thick: s0 = {s0 / MM:.0f} mm "
        f"({'posterior mean' if 's0' in tree else 'the cell’s'}).",
    )


def _test_pose_section(page: Page, prediction: TestPosePrediction, cell: Cell | None) -> None:
    page.heading("test_pose", "Error at the test pose")
    if not prediction.available:
        page.paragraph(f"Not available: {prediction.reason}.", css="warning")
        page.close()
        return
    if cell is not None:
        page.record("pose", {"q_deg": cell.test_q / DEG, "force_N": cell.test_wrench[:3], "moment_Nm": cell.test_wrench[3:]})
        page.paragraph(
            f"Test pose q = ({', '.join(f'{v / DEG:g}' for v in cell.test_q)}) deg, wrench f = "
            f"({', '.join(f'{v:g}' for v in cell.test_wrench[:3])}) N, m = ({', '.join(f'{v:g}' for v in cell.test_wrench[3:])}) N·m. "
            "The compensation applies the draws' median of each parameter (the cell's value for what the campaign "
            "does not identify); what is left is the spread of the draws about it, as `bayescal compensate` gives it."
        )
    numbers = prediction.to_json()
    frame = pd.DataFrame.from_dict(numbers["deflection_mm"], orient="index")
    frame.loc["|δ|"] = numbers["deflection_norm_mm"]
    frame = pd.DataFrame({"mean [mm]": frame["mean"], "±3σ [mm]": 3 * frame["sd"]}, index=pd.Index(frame.index, name="deflection"))
    page.table("deflection_mm", frame, shown=table_texts(frame, {"mean [mm]": "±3σ [mm]", "±3σ [mm]": "±3σ [mm]"}))
    error_mm = numbers["residual_error_mm"]
    words = {"rms": "rms over the draws", "q95": "95 % of draws below", "q99.73": "99.73 % of draws below"}
    error = pd.DataFrame(
        {
            "everything counted [μm]": {key: error_mm[key] * MM / UM for key in words},
            "identified parameters only [μm]": {key: error_mm["identified_only"][key] * MM / UM for key in words},
        }
    )
    error.index.name = "error left after compensation"
    page.table("residual_error_um", error, shown=table_texts(error, {}, dict.fromkeys(error.columns, fixed(1))), row_words=lambda key: words.get(key, key))
    if error_mm["unidentified"]:
        page.paragraph(unidentified_sentence(error_mm))
        page.record("unidentified", {"names": error_mm["unidentified"], "priors": error_mm["priors"]})
    page.record("compensated_joints", numbers["joints"])
    to_um = MM / UM
    page.figure(
        "test_pose_error",
        plot_error_distribution(
            prediction.errors / UM, rms_um=error_mm["rms"] * to_um, q95_um=error_mm["q95"] * to_um, q9973_um=error_mm["q99.73"] * to_um
        ),
        "Distribution over the posterior of the positioning error left at the test pose.",
    )
    page.close()


def _study_section(page: Page, study: pd.DataFrame, source: str) -> None:
    page.heading("study", "q2-angle study")
    if source:
        page.paragraph(f"From {source}.")
    frame = study.copy()
    frame.index = pd.Index([str(i) for i in frame.index], name=frame.index.name or "row")
    page.table("table", frame)
    page.close()
