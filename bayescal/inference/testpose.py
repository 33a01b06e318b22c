"""Accuracy at the user's test pose: the posterior carried to a machining configuration (eqs 38-39).

Klimchik et al. judge a calibration by the positioning error left at a test
pose ``q0`` under its process wrench ``F0`` after the compliance error has
been compensated with the identified parameters.  Here every posterior draw of
the compliances predicts the tool point's deflection ``A0 k`` (eq 31 at the
test pose, plus the exact model's nonlinear correction when used); the
compensation applies the posterior-mean prediction, so the error left is the
spread of the draws about it.  Its root-mean-square is the paper's ``rho0``
(eq 38 with the posterior covariance instead of the sampling covariance, which
for this linear-Gaussian problem coincide); it is given both from the draws
and from the covariance, which must agree.  The design and the spread of the
draws are those of :mod:`bayescal.compensation.spread`, which the program
compensation (``bayescal compensate``) uses pose by pose: one code path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bayescal.cell.config import Cell
from bayescal.robot.compensator import Compensator
from bayescal.inference.exact import exact_deflections
from bayescal.inference.parameters import COMPLIANCE_UNIT
from bayescal.inference.results import ElastostaticResults
from bayescal.robot.kinematics import Robot
from bayescal.compensation.spread import deflection_draws, designs, error_quantiles
from bayescal.units import MM, URAD_PER_NM

__all__ = ["TestPosePrediction", "predict_test_pose", "predict_cell_test_pose"]

@dataclass(frozen=True)
class TestPosePrediction:
    """Predicted deflection at the test pose and the error left after compensation (SI).

    Attributes
    ----------
    deflection : numpy.ndarray
        ``(S, 3)`` deflection of the tool point predicted by each posterior draw (m, base axes).
    reference : numpy.ndarray
        ``(3,)`` the deflection the compensation uses (posterior mean) or the truth.
    rho0 : float
        ``sqrt(trace(A0 cov(k) A0'))`` (eq 38) from the posterior covariance (m).
    available : bool
        False when the campaign cannot predict the test pose.
    reason : str
        Why not, when not available.
    assumed : dict
        Compliances the campaign does not identify, held at their nominal value
        (rad/(N·m), m/N for a prismatic joint); their uncertainty is not in the prediction.
    units : dict
        The edge unit of each of ``assumed`` (the parameter registry's).
    """

    __test__ = False  # not a pytest test class despite its name

    deflection: np.ndarray
    reference: np.ndarray
    rho0: float
    available: bool = True
    reason: str = ""
    assumed: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)

    @property
    def errors(self) -> np.ndarray:
        """``(S,)`` length of the positioning error left by each draw (m)."""
        return np.linalg.norm(self.deflection - self.reference, axis=1)

    def to_json(self) -> dict:
        """The CLI's ``test_pose`` block, in mm."""
        if not self.available:
            return {"available": False, "reason": self.reason}
        assumed = {
            name: {
                "value": value / URAD_PER_NM,
                "unit": self.units.get(name, COMPLIANCE_UNIT),
                "note": "not identifiable from the campaign: held at the config's value",
            }
            for name, value in self.assumed.items()
        }
        mean = self.deflection.mean(axis=0)
        sd = self.deflection.std(axis=0, ddof=1)
        norms = np.linalg.norm(self.deflection, axis=1)
        errors = error_quantiles(self.errors)
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
            "residual_error_mm": {
                "rms": float(errors["rms"] / MM),
                "q95": float(errors["q95"] / MM),
                "q99.73": float(errors["q9973"] / MM),
                "rho0_from_covariance": self.rho0 / MM,
            },
            "assumed": assumed,
        }


def predict_test_pose(
    results: ElastostaticResults,
    robot: Robot,
    q0: np.ndarray,
    wrench0: np.ndarray,
    point: np.ndarray,
    *,
    nominal_compensator: Compensator | None = None,
    nominal_compliances: np.ndarray | None = None,
    load_point: np.ndarray | None = None,
    truth: np.ndarray | None = None,
) -> TestPosePrediction:
    """Carry the posterior to the test pose.

    Parameters
    ----------
    results
        An identification.
    robot
        The robot.
    q0
        ``(6,)`` test pose (rad).
    wrench0
        ``(6,)`` process wrench at the flange origin in base axes (N, N·m).
    point
        ``(3,)`` tool point in the flange frame (m).
    nominal_compensator
        With the exact model: the spring whose static torque balances the arm
        (as in the identification's correction).
    nominal_compliances
        ``(6,)`` values (rad/(N·m)) for joints the campaign cannot identify; without
        them such a joint makes the prediction unavailable.
    load_point
        With the exact model: where the wrench's force acts (None: dead load at the flange).
    truth
        ``(3,)`` true deflection (simulations): the error is then measured from it.
    """
    q0 = np.asarray(q0, dtype=float)
    # Without a compensator no joint's compliance depends on its angle.
    angle = math.nan if results.joint is None else float(q0[results.joint])
    draws = results.compliance_draws(angle, fill=nominal_compliances)
    if draws is None:
        return TestPosePrediction(
            deflection=np.empty((0, 3)),
            reference=np.full(3, math.nan),
            rho0=math.nan,
            available=False,
            reason=_unavailable(results, angle, nominal_compliances is None),
        )
    A0 = designs(robot, q0[np.newaxis], np.reshape(point, (1, 3)), np.reshape(wrench0, (1, 6)))[0]
    deflection = deflection_draws(A0[np.newaxis], draws)[0].T
    mean_k = draws.mean(axis=0)
    if results.model == "exact" and (nominal_compensator is not None or results.joint is None):
        own = mean_k.copy()
        if results.joint is not None:
            own[results.joint] = 1.0 / (1.0 / mean_k[results.joint] - nominal_compensator.stiffness(angle))
        exact = exact_deflections(
            robot,
            q0,
            wrench0,
            own,
            nominal_compensator,
            points_in_flange=np.atleast_2d(point),
            load_point=load_point,
            compensated_joint=results.joint,
        )[0]
        deflection = deflection + (exact - A0 @ mean_k)
    cov = np.cov(draws, rowvar=False)
    rho0 = float(np.sqrt(np.trace(A0 @ cov @ A0.T)))
    reference = deflection.mean(axis=0) if truth is None else np.asarray(truth, dtype=float)
    assumed = {
        f"k{j + 1}": float(draws[0, j])
        for j in range(draws.shape[1])
        if j != results.joint and f"k{j + 1}" not in results.draws.compliances
    }
    units = {name: results.registry[name].unit for name in assumed}
    return TestPosePrediction(deflection=deflection, reference=reference, rho0=rho0, assumed=assumed, units=units)


def predict_cell_test_pose(results: ElastostaticResults, cell: Cell, *, truth: np.ndarray | None = None) -> TestPosePrediction:
    """:func:`predict_test_pose` at the cell's test pose, its wrench and tool point.

    Joints the campaign cannot identify take the cell's compliances (reported as
    ``assumed``), and the exact model's correction uses the cell's compensator.
    """
    return predict_test_pose(
        results,
        cell.robot,
        cell.test_q,
        cell.test_wrench,
        cell.test_point,
        nominal_compensator=cell.compensator,
        nominal_compliances=cell.compliances,
        load_point=cell.test_point,
        truth=truth,
    )


def _unavailable(results: ElastostaticResults, q2: float, no_fill: bool) -> str:
    """Why the campaign cannot predict the test pose, naming the compliance that is missing."""
    reasons = results.identifiability.not_identifiable
    joints = range(results.closed_form.compliances.size)
    missing = [f"k{j + 1}" for j in joints if j != results.joint and f"k{j + 1}" not in results.draws.compliances]
    if missing and no_fill:
        names = ", ".join(missing)
        return f"{names} not identified by the campaign ({reasons.get(missing[0], 'not sampled')}) and no nominal value given"
    j = results.joint + 1
    return (
        f"joint {j}'s compliance at the test pose's q{j} = {math.degrees(q2):.2f} deg needs the compensator model, "
        f"and K_c is not identifiable: {reasons.get('K_c', 'not sampled')}"
    )
