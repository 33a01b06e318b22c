"""Accuracy at the user's test pose: the posterior carried to a machining configuration (eqs 38-39).

Klimchik et al. judge a calibration by the positioning error left at a test
pose ``q0`` under its process wrench ``F0`` after the compliance error has
been compensated with the identified parameters.  Here the test pose is a
one-pose program compensated exactly as ``bayescal compensate`` compensates
every pose (:func:`~bayescal.compensation.compensate.compensate_program`): the
same draws (the posterior's, and the cell's prior for what the campaign does
not identify, :mod:`bayescal.compensation.calibration`), the same applied
values (the draws' medians), the same corrected joint targets and the same
:class:`~bayescal.compensation.budget.ErrorBudget`.  So ``calibrate``, the
review and ``compensate`` on a program holding that pose print one answer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.compensation.budget import ErrorBudget
from bayescal.compensation.calibration import Calibration, calibration_from_tree
from bayescal.compensation.compensate import compensate_program
from bayescal.compensation.program import Program
from bayescal.compensation.spread import error_quantiles
from bayescal.compensation.test_pose_text import test_pose_lines
from bayescal.errors import InputError
from bayescal.units import MM

__all__ = ["TestPosePrediction", "predict_test_pose", "predict_cell_test_pose", "test_pose_program"]


@dataclass(frozen=True)
class TestPosePrediction:
    """Predicted deflection at the test pose, the correction and the error left after it (SI).

    Attributes
    ----------
    deflection : numpy.ndarray
        ``(S, 3)`` deflection of the tool point each draw predicts (m, base axes, eq 31).
    applied : numpy.ndarray
        ``(3,)`` the deflection the correction removes (the applied, median, compliances).
    budget : ErrorBudget or None
        The error left and the unidentified parameters' part of it.
    programmed : numpy.ndarray
        ``(n,)`` the test pose's joints (rad; m for a prismatic joint).
    corrected : numpy.ndarray
        ``(n,)`` the compensated joint targets ``bayescal compensate`` writes for it.
    position_units : tuple of str
        ``"deg"`` or ``"mm"`` per joint, with ``position_scale`` the SI value of one unit.
    available : bool
        False when the calibration cannot predict the test pose.
    reason : str
        Why not, when not available.
    """

    __test__ = False  # not a pytest test class despite its name

    deflection: np.ndarray
    applied: np.ndarray
    budget: ErrorBudget | None
    programmed: np.ndarray = field(default_factory=lambda: np.empty(0))
    corrected: np.ndarray = field(default_factory=lambda: np.empty(0))
    position_units: tuple[str, ...] = ()
    position_scale: np.ndarray = field(default_factory=lambda: np.empty(0))
    available: bool = True
    reason: str = ""

    @property
    def errors(self) -> np.ndarray:
        """``(S,)`` length of the positioning error each draw leaves after the correction (m)."""
        return np.linalg.norm(self.deflection - self.applied, axis=1)

    def against(self, truth: np.ndarray) -> dict[str, float]:
        """A simulation's check against the true deflection ``(3,)`` (m): rms, 95 % and 99.73 % of the draws' distance
        to it, and ``correction``, how far the applied correction misses it (mm)."""
        truth = np.asarray(truth, dtype=float)
        stats = error_quantiles(np.linalg.norm(self.deflection - truth, axis=1))
        return {
            "rms": float(stats["rms"] / MM),
            "q95": float(stats["q95"] / MM),
            "q99.73": float(stats["q9973"] / MM),
            "correction": float(np.linalg.norm(self.applied - truth) / MM),
        }

    def lines(self) -> list[str]:
        """The error budget in words, as ``bayescal calibrate`` prints it (:func:`~bayescal.compensation.test_pose_text.test_pose_lines`)."""
        return test_pose_lines(self.to_json())

    def to_json(self) -> dict:
        """The ``test_pose`` block of ``calibrate --json`` and the review, in mm and the joints' units."""
        if not self.available:
            return {"available": False, "reason": self.reason}
        mean = self.deflection.mean(axis=0)
        sd = self.deflection.std(axis=0, ddof=1)
        norms = np.linalg.norm(self.deflection, axis=1)
        return {
            "deflection_mm": {
                axis: {"mean": mean[i] / MM, "sd": sd[i] / MM, "lo3": (mean[i] - 3 * sd[i]) / MM, "hi3": (mean[i] + 3 * sd[i]) / MM}
                for i, axis in enumerate("xyz")
            },
            "deflection_norm_mm": {
                "mean": float(norms.mean() / MM),
                "sd": float(norms.std(ddof=1) / MM),
                "lo3": float((norms.mean() - 3 * norms.std(ddof=1)) / MM),
                "hi3": float((norms.mean() + 3 * norms.std(ddof=1)) / MM),
            },
            "corrected_deflection_mm": {axis: float(self.applied[i] / MM) for i, axis in enumerate("xyz")}
            | {"norm": float(np.linalg.norm(self.applied) / MM)},
            "residual_error_mm": self.budget.pose_json(0),
            "joints": {
                f"q{j + 1}": {
                    f"programmed_{unit}": float(self.programmed[j] / scale),
                    f"compensated_{unit}": float(self.corrected[j] / scale),
                }
                for j, (unit, scale) in enumerate(zip(self.position_units, self.position_scale))
            },
        }


def test_pose_program(cell: Cell, q0: np.ndarray, wrench0: np.ndarray, point: np.ndarray) -> Program:
    """The one-pose program of a test pose whose wrench ``(6,)`` is referred to the flange origin (base axes),
    as the cell's ``[test_pose] wrench_N_Nm`` is; a program's moment is about its tool point."""
    rotation, _ = cell.robot.flange_pose(q0)
    wrench = np.asarray(wrench0, dtype=float).copy()
    wrench[3:] -= np.cross(rotation @ point, wrench[:3])
    return Program(q=np.asarray(q0, dtype=float)[None], wrench=wrench[None], tcp=np.asarray(point, dtype=float)[None], table=pd.DataFrame(index=pd.Index([1], name="line")))


test_pose_program.__test__ = False  # not a pytest test despite its name


def predict_test_pose(calibration: Calibration, cell: Cell, q0: np.ndarray, wrench0: np.ndarray, point: np.ndarray) -> TestPosePrediction:
    """Compensate the pose ``q0`` under ``wrench0`` (at the flange origin, base axes) at tool point ``point``
    (flange frame, m) with ``calibration``, and give the error left over its draws."""
    results = compensate_program(test_pose_program(cell, q0, wrench0, point), calibration, cell, keep_spread=True)
    budget = results.budget
    applied = results.deflection_xyz[0]
    return TestPosePrediction(
        deflection=applied + budget.spread[0].T,
        applied=applied,
        budget=budget,
        programmed=np.asarray(q0, dtype=float),
        corrected=results.commands[0],
        position_units=tuple(cell.robot.position_units),
        position_scale=np.asarray(cell.robot.position_scale, dtype=float),
    )


def predict_cell_test_pose(results, cell: Cell) -> TestPosePrediction:
    """:func:`predict_test_pose` of an identification (:class:`~bayescal.inference.results.ElastostaticResults`)
    at the cell's test pose, wrench and tool point; not available, with the reason, when the posterior cannot
    predict the compensated joint there (no compensator model)."""
    try:
        calibration = calibration_from_tree(results.tree, cell)
    except InputError as error:
        reason = error.what
        first = None if cell.compensator is None else cell.compensator.PARAMETERS[0].name
        if first is not None and first not in results.tree["posterior"]:
            j = cell.compensated_joint
            reason = (
                f"joint {j + 1}'s compliance at the test pose's q{j + 1} = {np.degrees(cell.test_q[j]):.2f} deg needs the compensator "
                f"model, and {first} is not identifiable: {results.identifiability.not_identifiable.get(first, 'not sampled')}"
            )
        return TestPosePrediction(deflection=np.empty((0, 3)), applied=np.full(3, np.nan), budget=None, available=False, reason=reason)
    return predict_test_pose(calibration, cell, cell.test_q, cell.test_wrench, cell.test_point)
