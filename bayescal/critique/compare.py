"""Fitting the linear models and comparing them on held-out configurations.

A model is a design ``X`` (3 equations per campaign row) and a noise law. The
noise of equation ``i`` has standard deviation ``σ_g s_i``: ``s_i`` the
tracker's relative error at the row's positions (known), ``σ_g`` one unknown
level per base axis ``g``.

*Gaussian noise.*  The axis levels' ratios are estimated by iterated weighted
least squares; with them fixed, a flat prior on the coefficients and Jeffreys'
prior on the common scale give the Normal-inverse-gamma posterior, whose
predictive density for the equations of a held-out configuration is a
multivariate Student t with ``n - p`` degrees of freedom, location ``X_h β̂``
and scale ``s² (W_h⁻¹ + X_h (X'WX)⁻¹ X_h')``.  Leaving one configuration out
is therefore exact, without sampling.

*Student-t noise* (:data:`~bayescal.critique.extensions.OUTLIER_DOF` degrees of
freedom): the scale-mixture EM gives the coefficients and the axis levels;
the held-out predictive is the product of the equations' Student-t
densities, each widened by the coefficients' uncertainty
``x' (X'UWX)⁻¹ x`` (their correlation through the coefficients, small beside
the noise, is neglected).

The models are compared by the expected log predictive density of held-out
configurations (leave-one-configuration-out), with the standard error of the
difference ``sqrt(K var(d))`` over the ``K`` configurations' differences ``d``
(Vehtari, Gelman & Gabry 2017).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, special, stats

from bayescal.critique.extensions import OUTLIER_DOF
from bayescal.inference.identifiability import independent_columns

__all__ = ["Fit", "CrossValidation", "Comparison", "fit", "cross_validate", "compare", "compare_elpd"]

AXIS_ITERATIONS = 3
"""Reweightings for the axis noise levels (their ratios settle to 1e-3 within three on twin campaigns)."""
EM_ITERATIONS = 200
EM_TOLERANCE = 1e-4
"""EM of the Student-t noise stops when no coefficient moves by more than this fraction of its sd."""


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


@dataclass(frozen=True)
class Comparison:
    """How much better model B predicts held-out configurations than model A.

    Attributes
    ----------
    delta_elpd : float
        ``ELPD_B - ELPD_A``, nats.
    se : float
        Standard error of the difference, nats.
    n_configs : int
    """

    delta_elpd: float
    se: float
    n_configs: int

    def to_json(self) -> dict:
        return {"delta_elpd": round(self.delta_elpd, 3), "se": round(self.se, 3), "n_configs": self.n_configs}


def compare(a: CrossValidation, b: CrossValidation) -> Comparison:
    """Held-out comparison of ``b`` against ``a`` (fitted to the same equations)."""
    return compare_elpd(a.elpd, b.elpd)


def compare_elpd(a: np.ndarray, b: np.ndarray) -> Comparison:
    """Held-out comparison of model B against model A from their ``(K,)`` log predictive densities of the same K held-out units."""
    difference = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
    k = difference.size
    se = float(np.sqrt(k * np.var(difference, ddof=1))) if k > 1 else float("inf")
    return Comparison(delta_elpd=float(difference.sum()), se=se, n_configs=k)
