"""Figures of the calibration review: rank plots, pair plots, residuals, the test-pose error, a critique's evidence.

Like :mod:`bayescal.reports.plots`, every function builds a
:class:`matplotlib.figure.Figure` without touching pyplot's global state and
returns it; the caller saves it.  Values arrive in the units they are drawn in
(named in each parameter's label), so the functions convert nothing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import StepPatch
from numpy.typing import ArrayLike

__all__ = ["plot_rank", "plot_pairs", "plot_residuals", "plot_error_distribution", "plot_evidence", "AXIS_COLOURS"]

AXIS_COLOURS = {"x": "C0", "y": "C1", "z": "C2"}
"""One colour per base axis, the same in every figure."""
RANK_BINS = 20
"""Bins of a rank histogram: with a few hundred draws per chain, about 20 per bin and chain at the least."""
PAIR_POINTS = 2000
"""Draws shown in a pair plot's scatter panels: more only hide one another."""


def plot_rank(draws: Mapping[str, ArrayLike], *, columns: int = 3) -> Figure:
    """Rank histograms of each parameter's draws, one line per chain (Vehtari et al. 2021).

    Well-mixed chains give flat, overlapping histograms; a chain stuck in one region
    shows as a histogram piled up at one end.

    Parameters
    ----------
    draws
        Label (with its unit) to draws of shape ``(chain, draw)``.
    columns
        Panels per row.
    """
    names = list(draws)
    rows = max(1, -(-len(names) // columns))
    figure = Figure(figsize=(3.4 * columns, 2.4 * rows), layout="constrained")
    axes = np.atleast_1d(figure.subplots(rows, columns, squeeze=False)).ravel()
    for ax, name in zip(axes, names):
        values = np.asarray(draws[name], dtype=float)
        ranks = np.argsort(np.argsort(values, axis=None)).reshape(values.shape)
        edges = np.linspace(0, values.size, RANK_BINS + 1)
        expected = values.shape[1] / RANK_BINS
        quantiles = edges / values.size
        heights = [np.histogram(ranks[chain], bins=edges)[0] / expected for chain in range(values.shape[0])]
        # The step patches ax.stairs() would add, in the colour cycle's order, with the data limits set once from their
        # corners: stairs() takes each patch's limits from every segment of its path, half of building 32 chains' panels.
        for chain, height in enumerate(heights):
            ax.add_artist(StepPatch(height, quantiles, baseline=None, fill=False, edgecolor=f"C{chain}", lw=1.0, label=f"chain {chain + 1}"))
        ax.update_datalim([(quantiles[0], min(map(np.min, heights))), (quantiles[-1], max(map(np.max, heights)))])
        ax.autoscale_view()
        ax.axhline(1.0, color="0.5", lw=0.8, ls="--")
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("rank quantile [-]", fontsize=8)
        ax.set_ylabel("count / uniform [-]", fontsize=8)
        ax.set_ylim(0, None)
        ax.tick_params(labelsize=7)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    if names:
        # Above the panels, where it hides no histogram; 16 chains in one row overflow a 3-panel figure, so at most 8 per row.
        figure.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncols=min(values.shape[0], 8), fontsize=8)
    return figure


def plot_pairs(
    draws: Mapping[str, ArrayLike], *, reference: Mapping[str, float] | None = None, reference_label: str = "reference", seed: int = 0
) -> Figure:
    """Marginal histograms and pairwise scatter of posterior draws (a corner plot).

    Parameters
    ----------
    draws
        Label (with its unit) to flat draws ``(S,)``, all of the same length.
    reference
        Label to a value drawn as a line (e.g. the paper's), where known.
    reference_label
        What the reference values are, for the legend.
    seed
        Seed of the thinning of the scatter panels to :data:`PAIR_POINTS` draws.
    """
    names = list(draws)
    n = len(names)
    values = {name: np.asarray(draws[name], dtype=float).ravel() for name in names}
    size = len(next(iter(values.values())))
    shown = np.random.default_rng(seed).choice(size, min(size, PAIR_POINTS), replace=False)
    figure = Figure(figsize=(2.5 * n + 0.6, 2.5 * n), layout="constrained")
    # The lower triangle only: an empty cell of the grid lays out as a hidden axes did, without its 3 ms.
    grid = figure.add_gridspec(n, n)
    axes = {(i, j): figure.add_subplot(grid[i, j]) for i in range(n) for j in range(i + 1)}
    reference = reference or {}
    for i, row in enumerate(names):
        for j, column in enumerate(names[: i + 1]):
            ax = axes[i, j]
            if i == j:
                # One filled step patch, not hist()'s 40 bar patches: the same pixels, 26 ms a panel drawn and saved against 39.
                ax.stairs(*np.histogram(values[row], bins=40), fill=True, color="C0", edgecolor="none", alpha=0.7)
                ax.set_yticks([])
                if row in reference:
                    ax.axvline(reference[row], color="C3", lw=1.2, ls="--", label=reference_label)
            else:
                ax.plot(values[column][shown], values[row][shown], ".", ms=1.5, color="C0", alpha=0.4)
                correlation = np.corrcoef(values[column], values[row])[0, 1]
                ax.text(0.04, 0.92, f"ρ = {correlation:+.2f}", transform=ax.transAxes, fontsize=8, va="top",
                        bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none", "pad": 1.5})
            # Offsets ("+1.847e2") would hide the values the reader compares with the tables.
            ax.ticklabel_format(axis="x", style="plain", useOffset=False)
            if i != j:
                ax.ticklabel_format(axis="y", style="plain", useOffset=False)
            if i == n - 1:
                ax.set_xlabel(column, fontsize=8)
                ax.tick_params(axis="x", labelrotation=30)
            else:
                ax.tick_params(axis="x", labelbottom=False)
            if j == 0 and i > 0:
                ax.set_ylabel(row, fontsize=8)
            elif i != j:
                ax.tick_params(axis="y", labelleft=False)
            ax.tick_params(labelsize=7)
    if any(name in reference for name in names):
        handles = [axes[k, k].get_legend_handles_labels() for k in range(n)]
        found = next(h for h in handles if h[0])
        figure.legend(*found, loc="upper right", fontsize=8)
    return figure


def plot_residuals(table: pd.DataFrame, covariates: Mapping[str, str], *, noise_um: ArrayLike | None = None) -> Figure:
    """Residuals of x, y and z against each covariate, with the tracker's ±3σ envelope.

    Parameters
    ----------
    table
        One row per measurement with the covariate columns and ``residual_x_um``,
        ``residual_y_um``, ``residual_z_um`` (μm).
    covariates
        Column to axis label (with its unit).
    noise_um
        ``(N,)`` nominal sd (μm) of each row's deflection coordinate: its ±3σ drawn as grey marks.
    """
    names = list(covariates)
    columns = 2
    rows = -(-len(names) // columns)
    figure = Figure(figsize=(11.0, 3.4 * rows), layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    for ax, name in zip(axes, names):
        x = table[name].to_numpy(dtype=float)
        jitter = 0.004 * (np.ptp(x) or 1.0)
        for k, axis in enumerate("xyz"):
            ax.plot(x + (k - 1) * jitter, table[f"residual_{axis}_um"], ".", ms=4, color=AXIS_COLOURS[axis], label=f"{axis} residual")
        if noise_um is not None:
            order = np.argsort(x)
            envelope = 3 * np.asarray(noise_um, dtype=float)[order]
            ax.plot(x[order], envelope, "_", color="0.45", ms=6, label="tracker ±3σ")
            ax.plot(x[order], -envelope, "_", color="0.45", ms=6)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_xlabel(covariates[name])
        ax.set_ylabel("residual [μm]")
        ax.grid(alpha=0.3)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    if names:
        figure.legend(*axes[0].get_legend_handles_labels(), loc="outside upper center", ncols=4, fontsize=9)
    return figure


def plot_error_distribution(errors_um: ArrayLike, *, rms_um: float, q95_um: float, q9973_um: float) -> Figure:
    """Distribution of the positioning error left at the test pose after compensation.

    Parameters
    ----------
    errors_um
        ``(S,)`` error length left by each posterior draw, μm.
    rms_um, q95_um, q9973_um
        Its rms and its 95 % and 99.73 % quantiles, μm, drawn as lines.
    """
    errors = np.asarray(errors_um, dtype=float)
    figure = Figure(figsize=(6.4, 3.8), layout="constrained")
    ax = figure.add_subplot()
    ax.stairs(*np.histogram(errors, bins=50), fill=True, color="C0", edgecolor="none", alpha=0.7, label=f"posterior draws ({errors.size})")
    for value, label, style in ((rms_um, "rms (ρ0, eq 38)", "-"), (q95_um, "95 % quantile", "--"), (q9973_um, "99.73 % quantile", ":")):
        ax.axvline(value, color="C3", lw=1.4, ls=style, label=f"{label}: {value:.1f} μm")
    ax.set_xlabel("positioning error left at the test pose [μm]")
    ax.set_ylabel("draws")
    ax.set_title("Error left after compliance compensation (eqs 38-39)", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return figure


def plot_evidence(candidates: Sequence[str], delta_elpd: ArrayLike, se: ArrayLike) -> Figure:
    """A critique's evidence: each candidate effect's gain in expected log predictive density, ±2 se.

    Parameters
    ----------
    candidates
        The candidate effects.
    delta_elpd, se
        ``(n,)`` their Δelpd over the calibrated model and its standard error (nats).
    """
    delta = np.asarray(delta_elpd, dtype=float)
    error = 2 * np.asarray(se, dtype=float)
    figure = Figure(figsize=(6.4, 0.5 * len(candidates) + 1.6), layout="constrained")
    ax = figure.add_subplot()
    position = np.arange(len(candidates))
    colours = ["C2" if d - e > 0 else "0.5" for d, e in zip(delta, error)]
    ax.barh(position, delta, xerr=error, color=colours, capsize=3)
    ax.set_yticks(position, list(candidates))
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_xlabel("Δelpd over the calibrated model [nats] (±2 se)")
    ax.set_title("Candidate effects: green where Δelpd − 2 se > 0", fontsize=9)
    ax.grid(axis="x", alpha=0.3)
    return figure
