"""The critique's held-out fits before they were batched over folds, kept verbatim for ``bench_critique.py``.

Every fold refitted by its own loop of weighted least squares (a factorisation per
reweighting), its columns checked by Gram-Schmidt, and the predictive densities taken
through ``scipy.stats``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, special, stats

from bayescal.critique.extensions import OUTLIER_DOF
from bayescal.inference.identifiability import independent_columns

AXIS_ITERATIONS = 3
EM_ITERATIONS = 200
EM_TOLERANCE = 1e-4


@dataclass(frozen=True)
class Fit:
    """A model fitted to some equations.

    Attributes
    ----------
    beta : numpy.ndarray
        (p,) coefficients.
    cov : numpy.ndarray
        (p, p) their posterior covariance.
    level : numpy.ndarray
        (3,) noise level ``σ_g`` per base axis (m per unit relative noise).
    dof : float
        Degrees of freedom of the predictive Student t.
    robust : bool
    """

    beta: np.ndarray
    cov: np.ndarray
    level: np.ndarray
    dof: float
    robust: bool

    def predict(self, X: np.ndarray) -> np.ndarray:
        return X @ self.beta

    def log_density(self, y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray) -> float:
        """Log predictive density of the equations ``y`` (jointly), m."""
        residual = y - X @ self.beta
        noise = (self.level[group] * scale) ** 2
        if self.robust:
            spread = np.sqrt(noise + np.einsum("ij,jk,ik->i", X, self.cov, X))
            return float(np.sum(stats.t.logpdf(residual / spread, self.dof) - np.log(spread)))
        covariance = np.diag(noise) + X @ self.cov @ X.T
        factor = linalg.cho_factor(covariance, lower=True)
        z = linalg.solve_triangular(factor[0], residual, lower=True)
        n, nu = len(y), self.dof
        log_det = 2.0 * np.sum(np.log(np.diag(factor[0])))
        return float(
            special.gammaln((nu + n) / 2)
            - special.gammaln(nu / 2)
            - n / 2 * np.log(nu * np.pi)
            - log_det / 2
            - (nu + n) / 2 * np.log1p(z @ z / nu)
        )

    def marginal_sd(self, X: np.ndarray, scale: np.ndarray, group: np.ndarray) -> np.ndarray:
        """Predictive scale of each equation (the Student t's scale parameter), m."""
        return np.sqrt((self.level[group] * scale) ** 2 + np.einsum("ij,jk,ik->i", X, self.cov, X))


def _wls(y, X, weight):
    # Normal equations on unit-norm columns: compliance and covariate columns differ in units by
    # many orders of magnitude, and independent_columns has bounded their collinearity.
    A = X * weight[:, np.newaxis]
    gram = X.T @ A
    norm = np.sqrt(np.diag(gram))
    factor = linalg.cho_factor(gram / np.outer(norm, norm))
    return linalg.cho_solve(factor, (A.T @ y) / norm) / norm


def fit(y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray, *, robust: bool = False) -> Fit:
    """Fit the linear model ``y = X β + noise`` (noise sd ``σ_group · scale``) to the equations given."""
    n, p = X.shape
    counts = np.bincount(group, minlength=3)
    present = counts > 0
    variance = np.ones(3)
    if not robust:
        for _ in range(AXIS_ITERATIONS):
            beta = _wls(y, X, 1.0 / (scale**2 * variance[group]))
            residual = (y - X @ beta) / scale
            variance = np.where(present, np.bincount(group, residual**2, minlength=3) / np.maximum(counts, 1), 1.0)
            variance = np.maximum(variance, 1e-30)
        weight = 1.0 / (scale**2 * variance[group])
        beta = _wls(y, X, weight)
        residual = y - X @ beta
        dof = n - p
        s2 = float(residual @ (weight * residual)) / dof
        gram = X.T @ (X * weight[:, np.newaxis])
        cov = s2 * np.linalg.inv(gram)
        return Fit(beta=beta, cov=cov, level=np.sqrt(s2 * variance), dof=float(dof), robust=False)
    nu = OUTLIER_DOF
    mixing = np.ones(n)
    beta = _wls(y, X, 1.0 / scale**2)
    residual = (y - X @ beta) / scale
    variance = np.where(present, np.bincount(group, residual**2, minlength=3) / np.maximum(counts, 1), 1.0)
    for _ in range(EM_ITERATIONS):
        weight = mixing / (scale**2 * variance[group])
        updated = _wls(y, X, weight)
        residual = (y - X @ updated) / scale
        mixing = (nu + 1) / (nu + residual**2 / variance[group])
        variance = np.where(present, np.bincount(group, mixing * residual**2, minlength=3) / np.maximum(counts, 1), 1.0)
        variance = np.maximum(variance, 1e-30)
        gram = X.T @ (X * (mixing / (scale**2 * variance[group]))[:, np.newaxis])
        cov = np.linalg.inv(gram)
        settled = np.all(np.abs(updated - beta) <= EM_TOLERANCE * np.sqrt(np.diag(cov)))
        beta = updated
        if settled:
            break
    return Fit(beta=beta, cov=cov, level=np.sqrt(variance), dof=nu, robust=True)


@dataclass(frozen=True)
class CrossValidation:
    """A model left-one-configuration-out.

    Attributes
    ----------
    configs : numpy.ndarray
        (K,) the configurations, in the order of ``elpd``.
    elpd : numpy.ndarray
        (K,) log predictive density of each configuration's equations with the model fitted to the others.
    predicted : numpy.ndarray
        (n,) the held-out prediction of every equation, m.
    sd : numpy.ndarray
        (n,) its predictive scale, m.
    pit : numpy.ndarray
        (n,) the leave-one-configuration-out probability integral transform of every equation.
    full : Fit
        The model fitted to all equations.
    columns : numpy.ndarray
        Indices of the design's columns the model kept.
    """

    configs: np.ndarray
    elpd: np.ndarray
    predicted: np.ndarray
    sd: np.ndarray
    pit: np.ndarray
    full: Fit
    columns: np.ndarray

    @property
    def total(self) -> float:
        return float(self.elpd.sum())


def cross_validate(
    y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray, config: np.ndarray, *, robust: bool = False
) -> CrossValidation:
    """Leave-one-configuration-out predictive densities of the model ``X`` (equations' ``config``)."""
    columns = independent_columns(X)
    X = X[:, columns]
    configs = np.unique(config)
    elpd = np.empty(configs.size)
    predicted = np.empty(y.size)
    sd = np.empty(y.size)
    pit = np.empty(y.size)
    for k, held in enumerate(configs):
        out = config == held
        # A column the other configurations do not excite (a torque reversal seen in the
        # held-out one only) has no estimate: the held-out prediction goes without it.
        keep = independent_columns(X[~out])
        model = fit(y[~out], X[~out][:, keep], scale[~out], group[~out], robust=robust)
        held_out = X[out][:, keep]
        elpd[k] = model.log_density(y[out], held_out, scale[out], group[out])
        predicted[out] = model.predict(held_out)
        sd[out] = model.marginal_sd(held_out, scale[out], group[out])
        pit[out] = stats.t.cdf((y[out] - predicted[out]) / sd[out], model.dof)
    full = fit(y, X, scale, group, robust=robust)
    return CrossValidation(configs=configs, elpd=elpd, predicted=predicted, sd=sd, pit=pit, full=full, columns=columns)
