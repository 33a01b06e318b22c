"""What the geometry report says, computed once: Table I through the closed-form fits and the posteriors.

:func:`geometry_findings` fits the closed forms (eqs 10-29) and the concentric
and rigid posteriors to a file of marker points, compares them with Table II
(:func:`bayescal.reference.beside_published`), runs the two Monte-Carlo studies
(:func:`~bayescal_studies.studies.arc_fit.arc_fit_study`,
:func:`~bayescal_studies.studies.geometry_coverage.coverage_study`), the cylinder markers'
study and the model criticism of :class:`~bayescal.critique.geometry.GeometryCritique`,
and decides what the report says of them; :mod:`bayescal_studies.reports.geometry` only
words and draws the :class:`GeometryFindings`.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.critique.geometry import GeometryCritique, GeometryCritiqueResults
from bayescal.geometry.arcs import LEVER_MARKER, CompensatorGeometryModel, GeometryFit, MarkerLayout, MarkerPoints, read_arc_points
from bayescal.geometry.posterior import GeometryPosterior, GeometryPosteriorModel, geometry_sampler
from bayescal.reference import beside_published, read_paper_reference
from bayescal.sampling.protocol import Sampler
from bayescal_studies.studies.arc_fit import TABLE_I_NOISE, arc_fit_study
from bayescal_studies.studies.cylinder_markers import along_arc_residuals, cylinder_marker_study, implied_cylinder_noise
from bayescal_studies.studies.geometry_coverage import coverage_study
from bayescal.units import MM

__all__ = ["COVERAGE_SAMPLER", "GeometryFindings", "geometry_findings"]

COVERAGE_SAMPLER = {"n_chains": 2, "n_tune": 400, "n_draws": 400}
"""Ensembles of the coverage study: short, since the study itself checks what they deliver."""

SAME_PATTERN = 0.5
"""Correlation of the cylinder markers' residual sequences above which their patterns are called the same."""

MODEL_MISFIT_RATIO = 2.0
"""Cylinder-marker rms, in multiples of P1's, above which the planar model is said to miss these markers' motion."""

FAR_BEYOND_NOISE = 10.0
"""Drift along the arc, in multiples of P1's rms residual, called far beyond the noise."""


@dataclass(frozen=True)
class GeometryFindings:
    """Every number and verdict of the geometry report; see :func:`geometry_findings`.

    Attributes
    ----------
    points_path, seed
        The data file and the seed of every random number used.
    points, closed
        The marker points and their closed-form fit (eqs 10-29).
    concentric, rigid
        The posteriors with concentric (the paper's) and rigid cylinder markers.
    paper
        The concentric posterior beside Table II, or ``None`` without a reference table.
    markers
        :func:`~bayescal_studies.studies.cylinder_markers.cylinder_marker_study` of the closed-form fit.
    along
        Per cylinder marker, the rigid model's along-arc residuals at its posterior mean (m).
    arc_study, coverage
        The two Monte-Carlo studies on campaigns shaped like the data.
    critique
        The held-out comparison of the two-step model with its extensions.
    s0_values, s0_published
        Free spring lengths (m) of the eta curves, and Table IV's among them (or ``None``).
    implied_noise
        σ_cylinder (mm) at which our a_x and a_y intervals would be Table II's (with ``paper``).
    closed_form_within_sd
        The closed-form a_y lies within one posterior sd of the posterior mean.
    same_pattern, model_misfit, wider
        The cylinder markers' residuals correlate beyond :data:`SAME_PATTERN`; their rms exceeds
        :data:`MODEL_MISFIT_RATIO` times P1's; their σ exceeds the one Table II's widths imply.
    drift_in_noise
        The cylinder markers' smallest drift along their arc in P1's rms residuals.
    drift_verdict
        ``"far beyond"``, ``"beyond"`` or ``"within"`` P1's noise.
    rigid_narrower
        The rigid model's a_x interval is narrower than the concentric one.
    """

    points_path: str
    seed: int
    points: MarkerPoints
    closed: GeometryFit
    concentric: GeometryPosterior
    rigid: GeometryPosterior
    paper: pd.DataFrame | None
    markers: pd.DataFrame
    along: dict[str, np.ndarray]
    arc_study: pd.DataFrame
    coverage: pd.DataFrame
    critique: GeometryCritiqueResults
    s0_values: tuple[float, ...]
    s0_published: float | None
    implied_noise: pd.Series | None
    closed_form_within_sd: bool
    same_pattern: bool
    model_misfit: bool
    wider: bool | None
    drift_in_noise: float
    drift_verdict: str
    rigid_narrower: bool


def _drift_verdict(beyond: float) -> str:
    if beyond > FAR_BEYOND_NOISE:
        return "far beyond"
    return "beyond" if beyond > 1.0 else "within"


def geometry_findings(
    points_path: str | PathLike[str],
    reference_path: str | PathLike[str] | None = None,
    seed: int = 1,
    n_arc_rep: int = 2000,
    n_coverage_rep: int = 200,
    sampler: Sampler | None = None,
) -> GeometryFindings:
    """Fit, sample, study and criticise the marker points at ``points_path``.

    Parameters
    ----------
    points_path
        Marker points (``data/table1_geometry.csv``).
    reference_path
        Published values (``data/paper_reference.csv``); ``None`` omits the comparison.
    seed
        Seed of every random number used.
    n_arc_rep, n_coverage_rep
        Replications of the two Monte-Carlo studies.
    sampler
        Sampler of the two posteriors of the data (default
        :func:`~bayescal.geometry.posterior.geometry_sampler`); the coverage
        study always uses :data:`COVERAGE_SAMPLER`.
    """
    rng = np.random.default_rng(seed)
    points = read_arc_points(points_path)
    reference = read_paper_reference(reference_path) if reference_path is not None else None
    closed = CompensatorGeometryModel().fit(points)
    concentric = GeometryPosteriorModel("concentric", sampler=sampler).fit(points, rng=rng)
    rigid = GeometryPosteriorModel("rigid", sampler=sampler).fit(points, rng=rng)
    summary, rigid_summary = concentric.summary(), rigid.summary()

    arc_study, coverage = _monte_carlo(points, closed, n_arc_rep, n_coverage_rep, rng)
    along = {name: along_arc_residuals(points, rigid.closed_form.p0[:2], name, rigid.residuals[name]) for name in points.cylinder_markers}
    s0_values, s0_published = _s0_values(concentric.geometry, reference)
    markers = cylinder_marker_study(points, closed)
    critique = GeometryCritique().run(points)
    paper = beside_published(summary.loc[["L", "a_x", "a_y"], ["mean", "sd"]], "II", reference) if reference is not None else None
    implied = implied_cylinder_noise(summary, paper) if paper is not None else None
    return GeometryFindings(
        points_path=str(points_path),
        seed=seed,
        points=points,
        closed=closed,
        concentric=concentric,
        rigid=rigid,
        paper=paper,
        markers=markers,
        along=along,
        arc_study=arc_study,
        coverage=coverage,
        critique=critique,
        s0_values=s0_values,
        s0_published=s0_published,
        implied_noise=implied,
        **_verdicts(closed, summary, rigid_summary, markers, implied),
    )


def _monte_carlo(
    points: MarkerPoints, closed: GeometryFit, n_arc_rep: int, n_coverage_rep: int, rng: np.random.Generator
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The arc-fit and the coverage studies on the layout fitted to ``points``, at Table I's angles and noise."""
    q2_sorted = np.sort(points.of(LEVER_MARKER)[0])
    layout = MarkerLayout.from_fit(closed, points)
    arc_study = arc_fit_study(layout, q2_sorted, TABLE_I_NOISE, n_arc_rep, rng)
    light = GeometryPosteriorModel("concentric", sampler=geometry_sampler(**COVERAGE_SAMPLER))
    return arc_study, coverage_study(layout, q2_sorted, TABLE_I_NOISE, n_coverage_rep, light, rng)


def _s0_values(g, reference: pd.DataFrame | None) -> tuple[tuple[float, ...], float | None]:
    """The free lengths s0 (m) the report tries, the published one among them, and the published one (None: none)."""
    s0_values = [0.0, 0.2, 0.4]
    s0_published = None
    if reference is not None and "s0" in reference.index:
        s0_published = float(reference.loc["s0", "value"]) * MM
        s0_values.append(s0_published)
    s0_values.append(g.a - g.L)
    return tuple(s0_values), s0_published


def _verdicts(closed: GeometryFit, summary: pd.DataFrame, rigid_summary: pd.DataFrame, markers: pd.DataFrame, implied) -> dict:
    """The findings' verdicts on the fits and the cylinder markers (:class:`GeometryFindings`' fields by name)."""
    lever_rms = closed.residuals_rms[LEVER_MARKER] / MM
    beyond = float(markers["drift_along_arc_mm"].min() / lever_rms)
    return {
        "closed_form_within_sd": bool(abs(closed.geometry.a_y / MM - summary.loc["a_y", "mean"]) < summary.loc["a_y", "sd"]),
        "same_pattern": bool((markers["residual_correlation"] > SAME_PATTERN).all()),
        "model_misfit": bool(markers["residual_rms_mm"].max() / lever_rms > MODEL_MISFIT_RATIO),
        "wider": None if implied is None else bool(summary.loc["sigma[cylinder]", "mean"] > implied.max()),
        "drift_in_noise": beyond,
        "drift_verdict": _drift_verdict(beyond),
        "rigid_narrower": bool(rigid_summary.loc["a_x", "sd"] < summary.loc["a_x", "sd"]),
    }
