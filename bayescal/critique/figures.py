"""Figures of a critique: held-out residuals against the covariates, and the LOO-PIT of the campaign critique."""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    # annotations only: the geometry critique loads SciPy's optimiser, which the figures never call
    from bayescal.critique.geometry import GeometryCritiqueResults
    from bayescal.critique.results import CritiqueResults

__all__ = ["write_figures", "write_geometry_figures"]

PLOTTED = {
    "q2_deg": "q2 (deg)",
    "order": "order of measurement",
    "reach_mm": "reach (mm)",
    "tracker_distance_mm": "distance to the tracker (mm)",
}


FIGURES = ("residuals.png", "loo_pit.png")
"""The files :func:`write_figures` writes."""

GEOMETRY_FIGURES = ("geometry_residuals.png",)
"""The files :func:`write_geometry_figures` writes."""


def _pyplot(folder: str | PathLike[str]):
    """pyplot on the file-only backend, and the output folder, created if needed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return plt, folder


def write_figures(results: CritiqueResults, folder: str | PathLike[str]) -> list[Path]:
    """Write ``residuals.png`` and ``loo_pit.png`` into ``folder`` (created if needed); return their paths."""
    plt, folder = _pyplot(folder)
    table = results.residuals
    final = " + ".join(c for c in results.causes if c != "unexplained") or "classical"
    figure, axes = plt.subplots(2, len(PLOTTED), figsize=(4 * len(PLOTTED), 6.5), sharey="row", squeeze=False)
    for row, (column, label) in enumerate((("classical_z", "classical"), ("final_z", final))):
        for ax, (covariate, name) in zip(axes[row], PLOTTED.items()):
            for axis, colour in zip("xyz", ("C0", "C1", "C2")):
                part = table[table["axis"] == axis]
                ax.plot(part[covariate], part[column], ".", color=colour, ms=3, label=axis)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_xlabel(name)
        axes[row, 0].set_ylabel(f"held-out z, {label}")
    axes[0, 0].legend(title="axis", fontsize=7)
    figure.suptitle(f"{results.source}: verdict {results.verdict}, causes {results.causes or 'none'}")
    figure.tight_layout()
    residuals = folder / FIGURES[0]
    figure.savefig(residuals, dpi=120)
    plt.close(figure)

    figure, ax = plt.subplots(figsize=(5, 3.5))
    bins = np.linspace(0, 1, 21)
    ax.hist(table["classical_pit"], bins=bins, histtype="step", label="classical")
    ax.hist(table["final_pit"], bins=bins, histtype="step", label=final)
    ax.axhline(len(table) / (bins.size - 1), color="k", lw=0.5, ls="--")
    ax.set_xlabel("LOO-PIT (leave one configuration out)")
    ax.set_ylabel("equations")
    ax.legend(fontsize=7)
    figure.tight_layout()
    pit = folder / FIGURES[1]
    figure.savefig(pit, dpi=120)
    plt.close(figure)
    return [residuals, pit]


def write_geometry_figures(results: GeometryCritiqueResults, folder: str | PathLike[str]) -> list[Path]:
    """Write ``geometry_residuals.png`` into ``folder`` (created if needed): held-out residuals against q2 per marker."""
    plt, folder = _pyplot(folder)
    table = results.residuals
    final = " + ".join(c for c in results.causes if c != "unexplained") or "two-step"
    markers = list(dict.fromkeys(table["marker"]))
    figure, axes = plt.subplots(2, len(markers), figsize=(4 * len(markers), 6.5), sharex=True, squeeze=False)
    for row, (model, label) in enumerate((("two_step", "two-step"), ("final", final))):
        for ax, marker in zip(axes[row], markers):
            part = table[table["marker"] == marker].sort_values("q2_deg")
            for axis, colour in zip("xy", ("C0", "C1")):
                ax.plot(part["q2_deg"], part[f"{model}_{axis}_mm"], "o-", color=colour, ms=3, lw=0.8, label=axis)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(f"{marker}, {label}", fontsize=9)
        axes[row, 0].set_ylabel("held-out residual (mm)")
    for ax in axes[1]:
        ax.set_xlabel("q2 (deg)")
    axes[0, 0].legend(title="tracker axis", fontsize=7)
    figure.suptitle(f"{results.source}: verdict {results.verdict}, causes {results.causes or 'none'} (each angle left out in turn)")
    figure.tight_layout()
    path = folder / GEOMETRY_FIGURES[0]
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return [path]
