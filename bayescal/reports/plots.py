"""Figures for the reports: compensator stiffness curves and fitted marker arcs.

Every function builds a :class:`matplotlib.figure.Figure` without touching
pyplot's global state and returns it; the caller saves it.  Axes are in the
paper's units (mm, deg, μm for residuals).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

from bayescal.robot.compensator import Compensator, CompensatorGeometry
from bayescal.geometry.arcs import LEVER_MARKER, GeometryFit, MarkerPoints
from bayescal.geometry.layout import circular_mean
from bayescal.units import DEG, MM, UM, URAD_PER_NM

__all__ = ["plot_eta_curves", "plot_arc_fit", "plot_joint2_compliance"]


def plot_eta_curves(
    geometry: CompensatorGeometry,
    s0_values: Sequence[float],
    q2_range: tuple[float, float] = (-150 * DEG, 0.0),
    highlight: float | None = None,
) -> Figure:
    """The coefficient ``eta(q2)`` of eq 9 for several spring free lengths (the paper's Fig. 3).

    Parameters
    ----------
    geometry
        Compensator geometry (SI).
    s0_values
        Free lengths of the spring in m, one curve each.
    q2_range
        Joint-angle range in rad.
    highlight
        A free length (m) drawn thicker, e.g. an identified value.
    """
    q2 = np.linspace(*q2_range, 301)
    figure = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = figure.add_subplot()
    for s0 in s0_values:
        eta = Compensator(geometry.L, geometry.a_x, geometry.a_y, geometry.phi, 1.0, s0).eta(q2)
        thick = highlight is not None and np.isclose(s0, highlight)
        ax.plot(q2 / DEG, eta, lw=2.4 if thick else 1.2, label=f"s0 = {s0 / MM:.0f} mm")
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("q2 [deg]")
    ax.set_ylabel("η(q2) [-]")
    ax.set_title(
        f"Compensator stiffness coefficient, L = {geometry.L / MM:.2f} mm, a = {geometry.a / MM:.2f} mm, "
        f"α = {geometry.alpha / DEG:.2f}°",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return figure


def plot_arc_fit(
    points: MarkerPoints,
    fit: GeometryFit,
    cylinder_residuals: Mapping[str, Mapping[str, ArrayLike]] | None = None,
) -> Figure:
    """Marker points with the fitted arcs, and the residuals of each marker.

    Parameters
    ----------
    points
        The marker points (x, y used).
    fit
        The closed-form fit: its lever arc, its concentric arcs and their centres are drawn.
    cylinder_residuals
        Optional residuals of the cylinder markers under other models, drawn
        beside the concentric fit's radial residuals, as ``{label: {marker:
        residuals in m}}`` (one value per point in the order of ``points.of(marker)``).
    """
    figure = Figure(figsize=(11.0, 4.2), layout="constrained")
    overview, lever_ax, cylinder_ax = figure.subplots(1, 3, width_ratios=[1.3, 1.0, 1.0])
    _draw_arcs(overview, points, fit)
    _draw_lever_residuals(lever_ax, points, fit)
    _draw_cylinder_residuals(cylinder_ax, points, fit, cylinder_residuals)
    return figure


def _draw_arcs(overview, points: MarkerPoints, fit: GeometryFit) -> None:
    """The marker points with the fitted arcs, their centres p0 and p2, mm."""
    q1, p1 = points.of(LEVER_MARKER)
    sweep = np.linspace(min(q1.min(), 0.0) - 10 * DEG, max(q1.max(), 0.0) + 10 * DEG, 200)
    arc = fit.lever.predict(sweep)
    overview.plot(arc[:, 0] / MM, arc[:, 1] / MM, color="C0", lw=1)
    overview.plot(p1[:, 0] / MM, p1[:, 1] / MM, "o", color="C0", label="P1")
    p0 = fit.p0[:2]
    for k, name in enumerate(points.cylinder_markers, start=1):
        _, xyz = points.of(name)
        d = xyz[:, :2] - p0
        beta = np.arctan2(d[:, 1], d[:, 0])
        centre_beta = circular_mean(beta)
        span = np.max(np.abs(np.angle(np.exp(1j * (beta - centre_beta))))) + 10 * DEG
        b = centre_beta + np.linspace(-span, span, 100)
        radius = fit.cylinder.radii[name]
        overview.plot((p0[0] + radius * np.cos(b)) / MM, (p0[1] + radius * np.sin(b)) / MM, color=f"C{k}", lw=1)
        overview.plot(xyz[:, 0] / MM, xyz[:, 1] / MM, "s", color=f"C{k}", ms=4, label=name)
    for centre, label in ((fit.p2[:2], "p2"), (p0, "p0")):
        overview.plot(centre[0] / MM, centre[1] / MM, "k+", ms=10)
        overview.annotate(label, centre / MM, textcoords="offset points", xytext=(4, 4))
    overview.plot([p0[0] / MM, fit.p2[0] / MM], [p0[1] / MM, fit.p2[1] / MM], "k:", lw=0.8)
    overview.set_aspect("equal")
    overview.set_xlabel("x [mm]")
    overview.set_ylabel("y [mm]")
    overview.set_title("Marker points and fitted arcs", fontsize=9)
    overview.legend(fontsize=8)


def _draw_lever_residuals(lever_ax, points: MarkerPoints, fit: GeometryFit) -> None:
    """P1's residuals of the known-angle fit against q2, μm."""
    q1, _ = points.of(LEVER_MARKER)
    residuals = fit.lever.residuals[:, :2]
    order = np.argsort(q1)
    for column, label in enumerate(("x", "y")):
        lever_ax.plot(q1[order] / DEG, residuals[order, column] / UM, "o-", label=f"P1 {label}")
    lever_ax.axhline(0.0, color="0.6", lw=0.8)
    lever_ax.set_xlabel("q2 [deg]")
    lever_ax.set_ylabel("residual [μm]")
    lever_ax.set_title(f"P1, known-angle fit (rms {fit.residuals_rms[LEVER_MARKER] / UM:.0f} μm)", fontsize=9)
    lever_ax.legend(fontsize=8)


def _draw_cylinder_residuals(
    cylinder_ax, points: MarkerPoints, fit: GeometryFit, cylinder_residuals: Mapping[str, Mapping[str, ArrayLike]] | None
) -> None:
    """The cylinder markers' residuals against q2, μm: the concentric fit's radial ones and ``cylinder_residuals``'."""
    models = {"concentric (radial)": {name: fit.cylinder.residuals[name] for name in points.cylinder_markers}}
    models |= {label: dict(res) for label, res in (cylinder_residuals or {}).items()}
    for style, (label, by_marker) in zip(("o-", "s--", "^:"), models.items()):
        for k, name in enumerate(points.cylinder_markers, start=1):
            q, _ = points.of(name)
            order = np.argsort(q)
            values = np.asarray(by_marker[name])[order]
            cylinder_ax.plot(q[order] / DEG, values / UM, style, color=f"C{k}", label=f"{name} {label}")
    cylinder_ax.axhline(0.0, color="0.6", lw=0.8)
    cylinder_ax.set_xlabel("q2 [deg]")
    cylinder_ax.set_ylabel("residual [μm]")
    cylinder_ax.set_title("Cylinder markers", fontsize=9)
    cylinder_ax.legend(fontsize=7)


def plot_joint2_compliance(
    band: pd.DataFrame,
    angles: ArrayLike,
    per_angle_mean: ArrayLike,
    per_angle_sd: ArrayLike,
    own: float | None = None,
) -> Figure:
    """Joint 2's equivalent compliance against q2 with its posterior band (the paper's Fig. 7).

    Parameters
    ----------
    band
        Indexed by ``q2_deg``, columns ``low_urad_per_Nm``, ``median_urad_per_Nm``,
        ``high_urad_per_Nm`` and, for simulations, ``truth_urad_per_Nm``
        (:func:`~bayescal.inference.compliance_band.equivalent_compliance_band`).
    angles, per_angle_mean, per_angle_sd
        The campaign's q2 angles (rad) and the per-angle estimates (rad/(N·m)) of eq 33,
        drawn with ±3 sd bars.
    own
        The compliance of joint 2 without its compensator (1/K_theta2^0, rad/(N·m)), drawn dashed.
    """
    q2_deg = band.index.to_numpy(dtype=float)
    figure = Figure(figsize=(6.4, 4.2), layout="constrained")
    ax = figure.add_subplot()
    ax.fill_between(q2_deg, band["low_urad_per_Nm"], band["high_urad_per_Nm"], color="C0", alpha=0.25, lw=0, label="posterior 99.73 % band")
    ax.plot(q2_deg, band["median_urad_per_Nm"], color="C0", lw=1.6, label="posterior median")
    ax.errorbar(
        np.asarray(angles, dtype=float) / DEG,
        np.asarray(per_angle_mean, dtype=float) / URAD_PER_NM,
        yerr=3 * np.asarray(per_angle_sd, dtype=float) / URAD_PER_NM,
        fmt="o",
        color="C1",
        capsize=3,
        label="per-angle estimate ±3σ (eq 33)",
    )
    if "truth_urad_per_Nm" in band:
        ax.plot(q2_deg, band["truth_urad_per_Nm"], color="k", lw=1.0, ls=":", label="truth")
    if own is not None:
        ax.axhline(own / URAD_PER_NM, color="0.4", lw=1.0, ls="--", label="without compensator (1/K_θ2^0)")
    ax.set_xlabel("q2 [deg]")
    ax.set_ylabel("equivalent joint-2 compliance [μrad/(N·m)]")
    ax.set_title("Joint 2 with its gravity compensator (eq 8)", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return figure

