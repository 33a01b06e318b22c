"""What a calibration leaves unexplained: its residuals, row by row, beside the covariates they may depend on.

A model that describes the data leaves residuals that look like the tracker's
noise whatever the configuration; a trend against q2, the load or the distance
to the tracker points at an effect the model lacks (a compensator misfit, a
load-dependent stiffness, a tracker noise model that is off).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.inference.equations import deflection_noise
from bayescal.inference.results import ElastostaticResults
from bayescal.units import DEG, MM, UM

__all__ = ["residual_table", "COVARIATES"]

COVARIATES = {
    "q2_deg": "joint-2 angle q2 [deg]",
    "q3_deg": "joint-3 angle q3 [deg]",
    "load_N": "load force |f| [N]",
    "tracker_distance_mm": "distance to the tracker [mm]",
}
"""The covariates of :func:`residual_table` and how an axis names them."""


def residual_table(results: ElastostaticResults, campaign: Campaign, cell: Cell) -> pd.DataFrame:
    """One row per campaign row: the covariates, the residual of its deflection and that residual in tracker noise.

    Parameters
    ----------
    results
        The identification of ``campaign`` (its ``residuals`` are the closed-form fit's).
    campaign
        The campaign.
    cell
        The cell, whose tracker model gives each deflection's nominal noise.

    Returns
    -------
    pandas.DataFrame
        Columns ``config, repeat, marker``, the :data:`COVARIATES`, ``residual_x_um``,
        ``residual_y_um``, ``residual_z_um``, ``residual_um`` (length) and ``normalised``
        (each coordinate's residual over its nominal sd, the rms over x, y, z: about 1
        when the tracker model describes the data).
    """
    residuals = np.asarray(results.residuals, dtype=float)
    if residuals.shape != (len(campaign), 3):
        raise ValueError(f"results hold {residuals.shape[0]} residual rows, the campaign {len(campaign)}")
    noise = deflection_noise(cell.tracker, campaign)
    frame = pd.DataFrame(
        {
            "config": campaign.config.astype(int),
            "repeat": campaign.repeat.astype(int),
            "marker": campaign.marker.astype(str),
            "q2_deg": campaign.q[:, 1] / DEG,
            "q3_deg": campaign.q[:, 2] / DEG,
            "load_N": np.linalg.norm(campaign.wrench[:, :3], axis=1),
            "tracker_distance_mm": np.linalg.norm(campaign.p0 - cell.tracker.position, axis=1) / MM,
        }
    )
    for i, axis in enumerate("xyz"):
        frame[f"residual_{axis}_um"] = residuals[:, i] / UM
    frame["residual_um"] = np.linalg.norm(residuals, axis=1) / UM
    frame["normalised"] = np.sqrt(np.mean((residuals / noise[:, None]) ** 2, axis=1))
    return frame
