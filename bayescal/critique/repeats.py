"""What a campaign's repeats say of a critique's model: whether it misses them, as ``calibrate`` judges it.

The repeats' pure error sees a misfit of any shape
(:func:`~bayescal.inference.lack_of_fit.least_squares_lack_of_fit`): the scatter of each configuration's mean about
the model against the scatter of its repeats.  The critique asks it of its final model (a misfit it reveals that no
candidate matches is ``unexplained``), and of a candidate whose held-out gain is clear of one standard error but not
of the naming rule: one that leaves the repeats fitted accounts for the misfit they reveal
(:func:`~bayescal.critique.rule.accounts_for`, docs/critique.md, *Named by the repeats*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.critique.covariates import Rows
from bayescal.errors import InputError
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.lack_of_fit import LackOfFit, least_squares_lack_of_fit, line_of_sight, replicate_cells
from bayescal.robot.stiffness import EquilibriumError

__all__ = ["RepeatsCheck"]


@dataclass(frozen=True)
class RepeatsCheck:
    """``check(design)``: the lack of fit against the campaign's repeats of a model of design ``(3N, p)``.

    Build it with :meth:`of`.  ``y`` is the campaign's deflections less the exact model's nonlinearity (m per
    equation), which calibrate removes before judging the fit.
    """

    cell: Cell
    rows: Rows
    commanded: np.ndarray
    y: np.ndarray
    scale: np.ndarray

    @classmethod
    def of(cls, cell: Cell, campaign: Campaign, rows: Rows) -> RepeatsCheck:
        """The check of ``campaign`` (its rows :func:`~bayescal.critique.covariates.campaign_rows`) for ``cell``."""
        return cls(cell, rows, campaign.q, rows.y.reshape(-1) - _nonlinearity(cell, campaign), np.repeat(rows.noise, 3))

    def __call__(self, design: np.ndarray) -> LackOfFit | None:
        """The lack of fit of the model of ``design`` (3N, p), or None where the campaign has no repeats."""
        rows = self.rows
        return least_squares_lack_of_fit(
            self._calibration_design(design), self.y, self.scale, replicate_cells(rows.config, rows.marker),
            line_of_sight(rows.position, self.cell.tracker.position),
        )

    def _calibration_design(self, design: np.ndarray) -> np.ndarray:
        """The model's design with the compensated joint's compliance free at every angle of that joint, as calibrate fits it.

        The lack-of-fit test asks whether the calibration itself misses the repeats:
        a joint-2 compliance that varies with q2 (eq 8, whatever the spring) is part
        of the calibration model, not a misfit of it.
        """
        joint, rows = self.cell.compensated_joint, self.rows
        if joint is None:
            return design
        angles = np.unique(np.round(self.commanded[:, joint], 6), return_inverse=True)[1]
        per_angle = rows.design[:, :, joint, np.newaxis] * (angles[:, np.newaxis] == np.arange(angles.max() + 1))[:, np.newaxis, :]
        return np.concatenate([design.reshape(len(rows), 3, -1), per_angle], axis=2).reshape(3 * len(rows), -1)


def _nonlinearity(cell: Cell, campaign: Campaign) -> np.ndarray | float:
    """The exact model's nonlinearity (m per equation), which calibrate removes before judging the fit; 0 where it cannot.

    The exact model places the markers on the tool at the commanded pose, and
    refuses a campaign whose arm sags by degrees (a spring far off the cell's):
    there the lack of fit is judged on the linear model alone.
    """
    if cell.compensator is None:
        return 0.0
    try:
        return ElastostaticModel.from_cell(cell).nonlinearity(campaign)
    except (InputError, EquilibriumError):
        return 0.0
