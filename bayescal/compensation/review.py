"""What the review page shows of a calibration, computed once: the restored results, their residuals
and the prediction at the cell's test pose."""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.inference.elastostatic import restore_results
from bayescal.inference.priors import GeometryPrior
from bayescal.inference.results import ElastostaticResults
from bayescal.compensation.testpose import TestPosePrediction, predict_cell_test_pose
from bayescal.inference.residuals import residual_table

__all__ = ["CalibrationFindings", "calibration_findings"]


@dataclass(frozen=True)
class CalibrationFindings:
    """A calibration as the review renders it.

    Attributes
    ----------
    results
        The elastostatic results restored from their posterior.
    residuals
        :func:`~bayescal.inference.residuals.residual_table` of the results on their campaign.
    test_pose
        The prediction at the cell's test pose.
    """

    results: ElastostaticResults
    residuals: pd.DataFrame
    test_pose: TestPosePrediction


def calibration_findings(cell: Cell, campaign: Campaign, tree, geometry: GeometryPrior | None = None) -> CalibrationFindings:
    """Restore the calibration ``tree`` (a posterior DataTree) on ``campaign`` and ``cell``, with its residuals and test pose.

    Parameters
    ----------
    cell, campaign
        The cell and the campaign the calibration was computed from.
    tree
        The posterior DataTree written by ``bayescal calibrate --posterior``.
    geometry
        The geometry posterior it was computed with, or ``None``
        (:func:`~bayescal.inference.priors.posterior_geometry`).
    """
    results = restore_results(cell, campaign, tree, geometry)
    return CalibrationFindings(results, residual_table(results, campaign, cell), predict_cell_test_pose(results, cell))
