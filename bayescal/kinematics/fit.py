"""The kinematic calibration: the posterior of a rung's parameters given measured marker positions.

``KinematicCalibration(cell, rung).fit(positions)`` finds the posterior mode by
Levenberg-Marquardt on the priors and a Gaussian likelihood, and approximates the
posterior by the Gaussian at the mode (Laplace): the model is close to linear
there (parameters of mm and mrad on an arm of a metre), and the coverage of its
intervals is checked on simulated data (``tests/kinematics``).

The noise of a coordinate is the tracker's (the cell's ``[tracker]`` law) plus a
model error, an isotropic sd learned from the data by empirical Bayes: a real
robot's residuals are far above any tracker's noise (compliances not modelled,
gear play, thermal drift), and intervals from the tracker's noise alone would be
far too narrow.  The model error's variance is the residuals' mean square in
excess of the tracker's, corrected for the degrees of freedom the fit used.
"""

from __future__ import annotations

import numpy as np

from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.model import PointModel
from bayescal.kinematics.positions import Positions
from bayescal.kinematics.results import KinematicResults

__all__ = ["KinematicCalibration"]

MAX_ITERATIONS = 100
"""Levenberg-Marquardt steps at most; Justin's full model settles in about 20 from the nominal model."""

RELATIVE_TOLERANCE = 1e-7
"""A step that lowers the objective (about 1 per coordinate at the mode) by less than this fraction ends the search:
on Justin's 500 configurations that is a change below 0.001 in a value near 3,000, far inside the posterior."""

_NOISE_ROUNDS = 8
"""Alternations of the mode and the model error's variance; the variance settles to 1e-4 relative in 3-5."""


class KinematicCalibration:
    """A rung of the ladder, fitted to measured positions.

    Parameters
    ----------
    cell
        The cell of measured points.
    rung
        One of :data:`bayescal.kinematics.model.RUNGS` or :data:`~bayescal.kinematics.model.EXTENSIONS`.
    without
        Parameter groups left out (:data:`~bayescal.kinematics.model.GROUPS`).
    model
        A model with :class:`~bayescal.kinematics.model.PointModel`'s parameters, priors and ``predict``
        to fit instead of the rung's (one whose elastic part is an elastostatic model's,
        :mod:`bayescal.kinematics.elastic`); ``cell``, ``rung`` and ``without`` are then unused.
    """

    def __init__(self, cell: PointsCell, rung: str = "full", *, without: tuple[str, ...] = (), model: PointModel | None = None) -> None:
        self.model = PointModel(cell, rung, without=without) if model is None else model

    def fit(self, positions: Positions, *, start: KinematicResults | None = None) -> KinematicResults:
        """The posterior given ``positions`` (:class:`~bayescal.kinematics.positions.Positions`).

        ``start`` starts the search at another fit's mode and model error instead of the
        prior means (a fold's fit from the whole data's; parameters it lacks at their prior).
        """
        model = self.model
        q = model.cell.model_configuration(positions.joints)
        observed = positions.xyz
        tracker = model.cell.tracker.sigma(observed) ** 2
        theta = model.mean.copy()
        if start is not None:
            index = {name: i for i, name in enumerate(start.model.names)}
            for i, name in enumerate(model.names):
                if name in index:
                    theta[i] = start.mean[index[name]]
        precision = 1.0 / model.sd**2
        # Start from the starting point's own misfit: with the tracker's noise alone the objective is so peaked
        # that the first search crawls (Justin's full model: 117 steps from the nominal model, 79 this way).
        start_residual = observed - model.predict(theta, q, jacobian=False)[0]
        model_variance = max(float(np.mean(start_residual**2)), float(np.mean(tracker)))
        iterations = 0
        for _ in range(_NOISE_ROUNDS):
            variance = (tracker + model_variance)[..., None].repeat(3, axis=-1)
            theta, predicted, jacobian, steps = _mode(model, q, observed, variance, precision, theta)
            iterations += steps
            residual = observed - predicted
            information = _information(jacobian, variance)
            covariance = np.linalg.inv(information + np.diag(precision))
            used = float(np.sum(information * covariance))
            excess = float(np.sum(residual**2) / max(residual.size - used, 1.0) - np.mean(tracker))
            updated = max(excess, 0.0)
            settled = abs(updated - model_variance) <= 1e-4 * max(model_variance, 1e-12)
            model_variance = updated
            if settled:
                break
        variance = (tracker + model_variance)[..., None].repeat(3, axis=-1)
        theta, predicted, jacobian, steps = _mode(model, q, observed, variance, precision, theta)
        information = _information(jacobian, variance)
        covariance = np.linalg.inv(information + np.diag(precision))
        return KinematicResults(
            model=model,
            mean=theta,
            covariance=covariance,
            information=information,
            model_sd=float(np.sqrt(model_variance)),
            residuals=observed - predicted,
            positions=positions,
            iterations=iterations + steps,
        )


def _information(jacobian: np.ndarray, variance: np.ndarray) -> np.ndarray:
    """``Jᵀ W J`` of an ``(N, M, 3, P)`` Jacobian with per-coordinate variances ``(N, M, 3)``."""
    rows = jacobian.reshape(-1, jacobian.shape[-1])
    return rows.T @ (rows / variance.reshape(-1, 1))


def _mode(model: PointModel, q, observed, variance, precision, theta):
    """Levenberg-Marquardt on the negative log posterior; returns the mode, its predictions and Jacobian, the steps."""
    weights = 1.0 / variance

    def objective(predicted, parameters):
        residual = observed - predicted
        return float(np.sum(residual**2 * weights) + np.sum((parameters - model.mean) ** 2 * precision))

    predicted, jacobian = model.predict(theta, q)
    value = objective(predicted, theta)
    damping = 1e-3
    steps = 0
    for steps in range(1, MAX_ITERATIONS + 1):
        rows = jacobian.reshape(-1, model.size)
        hessian = rows.T @ (rows * weights.reshape(-1, 1)) + np.diag(precision)
        gradient = rows.T @ ((observed - predicted) * weights).reshape(-1) - precision * (theta - model.mean)
        improved = False
        while damping < 1e12:
            step = np.linalg.solve(hessian + damping * np.diag(np.diag(hessian)), gradient)
            trial, _ = model.predict(theta + step, q, jacobian=False)
            trial_value = objective(trial, theta + step)
            if trial_value < value:
                improved = True
                break
            damping *= 10.0
        if not improved:
            break
        gain = value - trial_value
        theta, value = theta + step, trial_value
        predicted, jacobian = model.predict(theta, q)
        damping = max(damping / 10.0, 1e-9)
        if gain <= RELATIVE_TOLERANCE * value:
            break
    return theta, predicted, jacobian, steps
