"""The review's sections on the campaign itself: what was measured, and what the fit leaves.

:func:`data_section` counts the campaign and gives the ranges of its angles,
loads, deflections and tracker noise; :func:`residual_section` plots the
residuals against their covariates and lists the rows furthest from the
tracker's noise.  Both render; the numbers come from the results and
:func:`bayescal.inference.residuals.residual_table`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.inference.equations import deflection_noise
from bayescal.inference.results import ElastostaticResults
from bayescal.reports.figures import plot_residuals
from bayescal.numbers import fixed, table_texts
from bayescal.reports.page import Page
from bayescal.sampling.summary import summarize
from bayescal.inference.residuals import COVARIATES
from bayescal.units import DEG, MM, UM

__all__ = ["data_section", "residual_section"]


def _range(values: np.ndarray) -> tuple[float, float]:
    return float(np.min(values)), float(np.max(values))


def data_section(page: Page, results: ElastostaticResults, campaign: Campaign, cell: Cell) -> None:
    page.heading("data", "The data")
    counts = {
        "rows": len(campaign),
        "configurations": int(np.unique(campaign.config).size),
        "repeats per configuration": int(np.unique(campaign.repeat).size),
        "markers": int(np.unique(campaign.marker).size),
        "scalar equations": results.n_equations,
        "distinct angles of the compensated joint": int(results.compensated_angles.size),
    }
    page.table("counts", pd.DataFrame({"value": list(counts.values())}, index=pd.Index(list(counts), name="campaign")))
    noise = deflection_noise(cell.tracker, campaign) / UM
    ranges = {f"q{j + 1} [deg]": _range(campaign.q[:, j] / DEG) for j in range(campaign.q.shape[1])}
    ranges["load force |f| [N]"] = _range(np.linalg.norm(campaign.wrench[:, :3], axis=1))
    ranges["load moment |m| [N·m]"] = _range(np.linalg.norm(campaign.wrench[:, 3:], axis=1))
    ranges["marker deflection [mm]"] = _range(np.linalg.norm(campaign.displacement, axis=1) / MM)
    ranges["tracker noise sd per deflection coordinate [μm]"] = _range(noise)
    frame = pd.DataFrame(ranges, index=["min", "max"]).T
    frame.index.name = "quantity"
    # A range is no estimate: joint angles to 0.1 deg, loads to 1 N, deflections and noise to 1 μm or 0.1 μm.
    shown = frame.map(lambda v: f"{v:.1f}")
    shown.loc[["load force |f| [N]", "load moment |m| [N·m]"]] = frame.loc[["load force |f| [N]", "load moment |m| [N·m]"]].map(lambda v: f"{v:.0f}")
    shown.loc["marker deflection [mm]"] = frame.loc["marker deflection [mm]"].map(lambda v: f"{v:.3f}")
    page.table("ranges", frame, shown=shown)
    tracker = cell.tracker
    page.record("tracker", {"factor": tracker.factor, "U0_um": tracker.U0 / UM, "U1_um_per_m": tracker.U1 / UM, "position_mm": tracker.position / MM})
    page.paragraph(
        f"Tracker model of the cell: sd = {tracker.factor:g} × ({tracker.U0 / UM:g} μm + {tracker.U1 / UM:g} μm/m × distance) "
        f"per coordinate, tracker at ({', '.join(f'{v / MM:.0f}' for v in tracker.position)}) mm; a deflection is the "
        "difference of two readings. Noise per group that the data show (posterior mean):"
    )
    sigma = summarize(results.tree, ["sigma"])
    frame = pd.DataFrame({"sd [μm]": sigma["mean"].to_numpy() * MM / UM}, index=pd.Index([n[6:-1] for n in sigma.index], name="noise group"))
    page.table("noise_by_group", frame, shown=table_texts(frame, {}, {"sd [μm]": fixed(1)}))
    page.close()


def residual_section(page: Page, results: ElastostaticResults, table: pd.DataFrame, campaign: Campaign, cell: Cell) -> None:
    page.heading("residuals", "Residuals")
    page.paragraph(
        f"Residuals of the closed-form fit (eqs 33-34{', after the exact model’s correction' if results.model == 'exact' else ''}): "
        f"rms {results.residual_rms / UM:.1f} μm per coordinate, "
        + (f"χ²/dof {results.chi2_per_dof:.3f} against the tracker model." if results.chi2_per_dof is not None else "no tracker model.")
    )
    page.record("residual_rms_um", results.residual_rms / UM)
    page.record("chi2_per_dof", results.chi2_per_dof)
    noise = deflection_noise(cell.tracker, campaign) / UM
    page.figure(
        "residuals",
        plot_residuals(table, COVARIATES, noise_um=noise),
        "Residual of each deflection coordinate against the covariates; grey: ±3σ of the tracker model for that row.",
    )
    worst = table.nlargest(5, "normalised")[["config", "repeat", "marker", "q2_deg", "residual_um", "normalised"]]
    worst.index = pd.Index([f"line {int(campaign.lines[i])}" if campaign.lines[i] else str(i) for i in worst.index], name="row")
    worst = worst.rename(columns={"q2_deg": "q2 [deg]", "residual_um": "residual [μm]", "normalised": "residual / tracker sd"})
    page.table(
        "largest",
        worst,
        shown=table_texts(worst, {}, {"q2 [deg]": fixed(1), "residual [μm]": fixed(1), "residual / tracker sd": fixed(1)}),
        caption="The five rows with the largest residual in units of the tracker noise",
    )
    page.close()
