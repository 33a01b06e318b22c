"""Checks of a model against held-out data: standardised residuals, LOO-PIT and residual structure.

All of them use the leave-one-configuration-out predictions of
:func:`~bayescal.critique.compare.cross_validate`, so that a model is judged on
configurations its fit did not see.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.critique.compare import CrossValidation
from bayescal.critique.covariates import Rows
from bayescal.critique.kolmogorov import ks_uniform
from bayescal.units import DEG, MM

__all__ = ["standardised_residuals", "pit_uniformity", "residual_summary", "residual_table", "OUTLIER_Z"]

OUTLIER_Z = 4.0
"""A held-out residual beyond this many predictive scales is counted as an outlier
(a Gaussian gives one in 16 000 equations beyond it)."""


def standardised_residuals(y: np.ndarray, cv: CrossValidation) -> np.ndarray:
    """(n,) held-out residuals divided by their predictive scale."""
    return (y - cv.predicted) / cv.sd


def pit_uniformity(cv: CrossValidation) -> dict:
    """Kolmogorov-Smirnov test of the LOO-PIT values against the uniform distribution.

    The PIT values of equations of one configuration are not independent (they share
    the held-out configuration's fit), so the p-value is a guide, not a test at its
    nominal level; the critique's verdict rests on the ELPD comparison.
    """
    statistic, p_value = ks_uniform(cv.pit)
    return {"ks_statistic": statistic, "p_value": p_value}


def residual_summary(y: np.ndarray, cv: CrossValidation, rows_per_equation: np.ndarray) -> dict:
    """Held-out residual statistics of a model, in mm.

    Parameters
    ----------
    y
        (n,) measured deflections, m, three equations per row.
    cv
        The model left-one-configuration-out.
    rows_per_equation
        (n,) the campaign row of each equation.
    """
    residual = y - cv.predicted
    z = residual / cv.sd
    per_row = np.sqrt(np.bincount(rows_per_equation, residual**2))
    return {
        "residual_rms_mm": float(np.sqrt(np.mean(residual**2)) / MM),
        "position_error_rms_mm": float(np.sqrt(np.mean(per_row**2)) / MM),
        "position_error_max_mm": float(per_row.max() / MM),
        "standardised_rms": float(np.sqrt(np.mean(z**2))),
        "outliers": int(np.sum(np.abs(z) > OUTLIER_Z)),
        "loo_pit": pit_uniformity(cv),
    }


def residual_table(rows: Rows, y: np.ndarray, base: CrossValidation, final: CrossValidation) -> pd.DataFrame:
    """One row per equation: its covariates and its held-out standardised residual and PIT under both models."""
    repeat = lambda values: np.repeat(values, 3)  # noqa: E731 - three equations per row
    return pd.DataFrame(
        {
            "config": repeat(rows.config),
            "marker": repeat(rows.marker),
            "axis": np.tile(np.array(["x", "y", "z"]), len(rows)),
            "order": repeat(rows.order),
            "q2_deg": repeat(rows.q[:, rows.plan_joint] / DEG),
            "reach_mm": repeat(np.hypot(rows.position[:, 0], rows.position[:, 1]) / MM),
            "tracker_distance_mm": repeat(rows.tracker_distance / MM),
            "load_N": repeat(np.linalg.norm(rows.wrench[:, :3], axis=1)),
            "deflection_mm": y / MM,
            "classical_z": (y - base.predicted) / base.sd,
            "final_z": (y - final.predicted) / final.sd,
            "classical_pit": base.pit,
            "final_pit": final.pit,
        }
    )
