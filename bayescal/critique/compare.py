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
freedom) per reading: a gross error (a broken beam, a mis-seated reflector, a
distance re-acquired off) puts one reading of one marker off in all three
coordinates at once, so the three equations of a row share one scale-mixing
weight (a trivariate t), and rows are independent.  The scale-mixture EM gives
the coefficients and the axis levels; the held-out predictive is the product of
the rows' trivariate t densities, each equation widened by the coefficients'
uncertainty ``x' (X'UWX)⁻¹ x`` (their correlation through the coefficients,
small beside the noise, is neglected).  Each equation's marginal is then a t
with the same degrees of freedom, which the PIT uses.

The models are compared by the expected log predictive density of held-out
configurations (leave-one-configuration-out), with the standard error of the
difference ``sqrt(K var(d))`` over the ``K`` configurations' differences ``d``
(Vehtari, Gelman & Gabry 2017).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg, special

from bayescal.critique.extensions import OUTLIER_DOF
from bayescal.inference.identifiability import COLLINEAR_TOLERANCE, independent_columns

__all__ = ["Fit", "CrossValidation", "Comparison", "fit", "cross_validate", "chosen", "compare", "compare_elpd", "smallest_unexplained_fraction"]

ROW_EQUATIONS = 3
"""Equations of one campaign row (one marker's deflection in one configuration and repeat), consecutive in
``y``: the coordinates of one marker's readings, which a gross error puts off together."""
AXIS_ITERATIONS = 3
"""Reweightings for the axis noise levels (their ratios settle to 1e-3 within three on twin campaigns)."""
EM_ITERATIONS = 200
EM_TOLERANCE = 1e-4
"""EM of the Student-t noise stops when no coefficient moves by more than this fraction of its sd."""
COLLINEAR_MARGIN = 2.0
"""Folds whose every column, judged from their Gram matrix, clears ``COLLINEAR_TOLERANCE`` by this factor keep all
columns without Gram-Schmidt; the others are checked by :func:`independent_columns` itself.  The Gram matrix squares
the columns' condition, so its estimate of a column's unexplained fraction is off by about ``1e-16 · cond²``; a factor
of 2 (a fraction of 2e-3, not 1e-3) leaves room for conditions up to about 1e6.  On the demo's campaign 2 of the
624 Gaussian fits of its critique fall below it (a fraction of 1.9e-3, then 0.08 and above) and are fitted alone
(``benchmarks/bench_critique.py`` prints the smallest)."""
DOWNDATE_FLOOR = 1e-6
"""A fold's Gram matrix is the campaign's less its held-out configuration's, which keeps about ``1e-16 / f`` of
relative precision in a column that keeps a fraction ``f`` of its sum of squares: a fold in which a column keeps
less than this fraction (a torque reversal seen mostly in the held-out configuration) is fitted alone."""


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

    def log_density(self, y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray, unit: np.ndarray | None = None) -> float:
        """Log predictive density of the equations ``y`` (jointly), m; ``unit`` (n,) the equations' mixing units of the
        Student-t noise (default: rows of :data:`ROW_EQUATIONS`)."""
        residual = y - X @ self.beta
        noise = (self.level[group] * scale) ** 2
        if self.robust:
            spread = np.sqrt(noise + np.einsum("ij,jk,ik->i", X, self.cov, X))
            return float(np.sum(_unit_t_logpdf(residual / spread, self.dof, _units(unit, y.size))) - np.sum(np.log(spread)))
        covariance = np.diag(noise) + X @ self.cov @ X.T
        factor = np.linalg.cholesky(covariance)
        z = linalg.solve_triangular(factor, residual, lower=True)
        n, nu = len(y), self.dof
        log_det = 2.0 * np.sum(np.log(np.diag(factor)))
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


def _units(unit: np.ndarray | None, n: int) -> np.ndarray:
    """(n,) consecutive mixing-unit indices from 0 (rows of :data:`ROW_EQUATIONS` by default)."""
    if unit is None:
        return np.arange(n) // ROW_EQUATIONS
    return np.unique(unit, return_inverse=True)[1]


def _unit_t_logpdf(z: np.ndarray, nu: float, unit: np.ndarray) -> np.ndarray:
    """Log density of each unit's standardised equations ``z`` (n,) under a multivariate t of ``nu`` dof (unit scale)."""
    # from scipy.special, as the PIT's stdtr: the fits need nothing of scipy.stats (0.34-0.36 s to import)
    d = np.bincount(unit)
    squares = np.bincount(unit, z**2)
    return special.gammaln((nu + d) / 2) - special.gammaln(nu / 2) - d / 2 * np.log(nu * np.pi) - (nu + d) / 2 * np.log1p(squares / nu)


def _wls(y, X, weight):
    # Normal equations on unit-norm columns: compliance and covariate columns differ in units by
    # many orders of magnitude, and independent_columns has bounded their collinearity.
    A = X * weight[:, np.newaxis]
    gram = X.T @ A
    norm = np.sqrt(np.diag(gram))
    factor = linalg.cho_factor(gram / np.outer(norm, norm))
    return linalg.cho_solve(factor, (A.T @ y) / norm) / norm


def fit(y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray, *, robust: bool = False, unit: np.ndarray | None = None) -> Fit:
    """Fit the linear model ``y = X β + noise`` (noise sd ``σ_group · scale``) to the equations given; with ``robust``,
    Student-t noise whose mixing weight each ``unit`` (n,) of equations shares (default: rows of :data:`ROW_EQUATIONS`)."""
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
    units = _units(unit, n)
    size = np.bincount(units)
    mixing = np.ones(n)
    beta = _wls(y, X, 1.0 / scale**2)
    residual = (y - X @ beta) / scale
    variance = np.where(present, np.bincount(group, residual**2, minlength=3) / np.maximum(counts, 1), 1.0)
    for _ in range(EM_ITERATIONS):
        weight = mixing / (scale**2 * variance[group])
        updated = _wls(y, X, weight)
        residual = (y - X @ updated) / scale
        mixing = ((nu + size) / (nu + np.bincount(units, residual**2 / variance[group])))[units]
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
    y: np.ndarray, X: np.ndarray, scale: np.ndarray, group: np.ndarray, config: np.ndarray, *, robust: bool = False,
    unit: np.ndarray | None = None,
) -> CrossValidation:
    """Leave-one-configuration-out predictive densities of the model ``X`` (equations' ``config``).

    Gaussian folds are fitted together (:func:`_gaussian_folds`): the normal equations of a fold are the
    whole campaign's less the held-out configuration's, per base axis, so that one pass over the equations
    serves every fold and reweighting; each fold's equations are then solved by one batched factorisation.
    A fold whose columns come near collinearity, and every fold of the Student-t model (whose weights are
    per row, or per ``unit`` (n,) of equations), are fitted alone by :func:`fit`.
    """
    columns = independent_columns(X)
    X = X[:, columns]
    configs, fold = np.unique(config, return_inverse=True)
    # the last of the batched fits holds nothing out: the model fitted to all equations
    batched = {} if robust else _gaussian_folds(y, X, scale, group, fold, configs.size + 1)
    unit = _units(unit, y.size)
    full = batched.pop(configs.size, None) or fit(y, X, scale, group, robust=robust, unit=unit)
    elpd = np.empty(configs.size)
    predicted = np.empty(y.size)
    sd = np.empty(y.size)
    pit = np.empty(y.size)
    together = _score_together(batched, y, X, scale, group, fold, elpd, predicted, sd, pit)
    for k in range(configs.size):
        if k in together:
            continue
        out = fold == k
        if k in batched:
            model, keep = batched[k], slice(None)
        else:
            # A column the other configurations do not excite (a torque reversal seen in the
            # held-out one only) has no estimate: the held-out prediction goes without it.
            keep = independent_columns(X[~out])
            model = fit(y[~out], X[~out][:, keep], scale[~out], group[~out], robust=robust, unit=unit[~out])
        held_out = X[out][:, keep]
        elpd[k] = model.log_density(y[out], held_out, scale[out], group[out], unit[out])
        predicted[out] = model.predict(held_out)
        sd[out] = model.marginal_sd(held_out, scale[out], group[out])
        pit[out] = special.stdtr(model.dof, (y[out] - predicted[out]) / sd[out])
    return CrossValidation(configs=configs, elpd=elpd, predicted=predicted, sd=sd, pit=pit, full=full, columns=columns)


def _score_together(models: dict[int, Fit], y, X, scale, group, fold, elpd, predicted, sd, pit) -> set[int]:
    """Held-out scores of the batched Gaussian folds whose configurations have the most equations in common, at once.

    :meth:`Fit.log_density`, :meth:`Fit.predict`, :meth:`Fit.marginal_sd` and the PIT of each such
    fold, written into ``elpd`` (K,), ``predicted``, ``sd`` and ``pit`` (n,); returns the folds scored.
    """
    if not models:
        return set()
    sizes = np.bincount(fold)
    candidates = np.array(sorted(models))
    size = np.bincount(sizes[candidates]).argmax()
    folds = candidates[sizes[candidates] == size]
    index = np.argsort(fold, kind="stable").reshape(-1)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    held = index[starts[folds][:, np.newaxis] + np.arange(size)]  # (F, m) equations of each fold
    beta = np.stack([models[k].beta for k in folds])
    cov = np.stack([models[k].cov for k in folds])
    level = np.stack([models[k].level for k in folds])
    nu = np.array([models[k].dof for k in folds])
    Xh = X[held]  # (F, m, p)
    mean = (Xh @ beta[:, :, np.newaxis])[:, :, 0]
    residual = y[held] - mean
    noise = (np.take_along_axis(level, group[held], axis=1) * scale[held]) ** 2
    spread = Xh @ cov @ np.swapaxes(Xh, 1, 2)
    factor = np.linalg.cholesky(spread + noise[:, :, np.newaxis] * np.eye(size))
    z = np.linalg.solve(factor, residual[:, :, np.newaxis])[:, :, 0]
    log_det = 2.0 * np.sum(np.log(np.diagonal(factor, axis1=1, axis2=2)), axis=1)
    elpd[folds] = (
        special.gammaln((nu + size) / 2)
        - special.gammaln(nu / 2)
        - size / 2 * np.log(nu * np.pi)
        - log_det / 2
        - (nu + size) / 2 * np.log1p(np.sum(z**2, axis=1) / nu)
    )
    scale_t = np.sqrt(noise + np.diagonal(spread, axis1=1, axis2=2))
    predicted[held] = mean
    sd[held] = scale_t
    pit[held] = special.stdtr(nu[:, np.newaxis], residual / scale_t)
    return set(folds.tolist())


def smallest_unexplained_fraction(X: np.ndarray, fold: np.ndarray, n_folds: int) -> np.ndarray:
    """(K,) per fold, the smallest fraction of a column of ``X`` (n, p) not explained by the columns before it.

    Taken from the fold's Gram matrix (the equations whose ``fold`` index is not the fold's): the
    diagonal of the Cholesky factor of its unit-diagonal form, the fraction :func:`independent_columns`
    compares with ``COLLINEAR_TOLERANCE``; 0 for a fold with a column that keeps less than
    :data:`DOWNDATE_FLOOR` of its sum of squares, or a Gram matrix that is not positive definite.
    """
    member = (fold == np.arange(n_folds)[:, np.newaxis]).astype(float)
    outer = (X[:, :, np.newaxis] * X[:, np.newaxis, :]).reshape(len(X), -1)
    gram = (outer.sum(axis=0) - member @ outer).reshape(n_folds, X.shape[1], X.shape[1])
    diagonal = np.diagonal(gram, axis1=1, axis2=2)
    fraction = np.zeros(n_folds)
    usable = np.all(diagonal > DOWNDATE_FLOOR * np.sum(X**2, axis=0), axis=1)
    if not np.any(usable):
        return fraction
    norm = np.sqrt(diagonal[usable])
    try:
        factor = np.linalg.cholesky(gram[usable] / (norm[:, :, np.newaxis] * norm[:, np.newaxis, :]))
    except np.linalg.LinAlgError:
        return fraction
    fraction[usable] = np.nan_to_num(np.diagonal(factor, axis1=1, axis2=2).min(axis=1))
    return fraction


def _gaussian_folds(y, X, scale, group, fold, n_folds: int) -> dict[int, Fit]:
    """Gaussian fits of every fold whose columns are clearly independent, by fold index: :func:`fit` batched over folds.

    Per fold and base axis the normal equations (``A'A``, ``A'z`` with ``A = X / scale``, ``z = y / scale``)
    are the campaign's less the fold's held-out configuration's; each reweighting combines them with the
    axis levels and solves all folds with one batched Cholesky factorisation, on unit-norm columns as
    :func:`fit` does.  The residuals are taken from the equations themselves, not from the normal equations,
    so that a close fit loses no digits.
    """
    n, p = X.shape
    clear = smallest_unexplained_fraction(X, fold, n_folds) > COLLINEAR_MARGIN * COLLINEAR_TOLERANCE
    if not np.any(clear):
        return {}
    A, z = X / scale[:, np.newaxis], y / scale
    held = fold == np.arange(n_folds)[:, np.newaxis]  # (K, n)
    axis = group == np.arange(3)[:, np.newaxis]  # (3, n)
    held_axis = (held[:, np.newaxis, :] & axis[np.newaxis]).reshape(3 * n_folds, n).astype(float)
    outer = (A[:, :, np.newaxis] * A[:, np.newaxis, :]).reshape(n, -1)
    gram = (axis.astype(float) @ outer)[np.newaxis] - (held_axis @ outer).reshape(n_folds, 3, -1)
    gram = gram.reshape(n_folds, 3, p, p)[clear]
    moment = A * z[:, np.newaxis]
    rhs = ((axis.astype(float) @ moment)[np.newaxis] - (held_axis @ moment).reshape(n_folds, 3, p))[clear]
    train = (~held[clear])[:, np.newaxis, :] & axis[np.newaxis]  # (F, 3, n)
    counts = train.sum(axis=2)
    present = counts > 0

    def solve(variance):
        weighted = np.sum(gram / variance[:, :, np.newaxis, np.newaxis], axis=1)
        norm = np.sqrt(np.diagonal(weighted, axis1=1, axis2=2))
        factor = np.linalg.cholesky(weighted / (norm[:, :, np.newaxis] * norm[:, np.newaxis, :]))
        b = np.sum(rhs / variance[:, :, np.newaxis], axis=1) / norm
        inner = np.linalg.solve(factor, b[:, :, np.newaxis])
        beta = np.linalg.solve(np.swapaxes(factor, 1, 2), inner)[:, :, 0] / norm
        squares = ((z[np.newaxis] - beta @ A.T) ** 2)[:, np.newaxis, :] * train
        return beta, squares.sum(axis=2), weighted

    variance = np.ones(counts.shape)
    for _ in range(AXIS_ITERATIONS):
        _, squares, _ = solve(variance)
        variance = np.maximum(np.where(present, squares / np.maximum(counts, 1), 1.0), 1e-30)
    beta, squares, gram_weighted = solve(variance)
    dof = counts.sum(axis=1) - p
    s2 = (squares / variance).sum(axis=1) / dof
    cov = s2[:, np.newaxis, np.newaxis] * np.linalg.inv(gram_weighted)
    level = np.sqrt(s2[:, np.newaxis] * variance)
    return {
        int(k): Fit(beta=beta[i], cov=cov[i], level=level[i], dof=float(dof[i]), robust=False)
        for i, k in enumerate(np.flatnonzero(clear))
    }


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


def chosen(variants: Sequence[CrossValidation]) -> tuple[int, CrossValidation]:
    """The variant of a candidate with the largest held-out total, and the candidate's cross-validation with its
    variant unknown.

    Choosing among variants by the same held-out scores a candidate is then judged by makes its score optimistic:
    the largest of several noisy totals (the selection bias of cross-validation, Cawley & Talbot 2010; Piironen &
    Vehtari 2017).  The variant is instead a discrete parameter, uniform a priori, integrated out with each
    configuration held out of its weights as it is of the fit: configuration k is predicted by the variants' mixture
    weighted by ``exp`` of their log predictive densities of the other configurations (the pseudo-marginal
    likelihood, Geisser & Eddy 1979; the pseudo-BMA weights of Yao et al. 2018).  Where one variant leads by many
    nats the mixture is that variant; where several predict alike it loses little to the best of them.  The
    predictions and the fit are those of the variant of largest total.  One variant: its cross-validation,
    unchanged.

    Parameters
    ----------
    variants : sequence of CrossValidation
        V ≥ 1 cross-validations of the same equations, one per variant.

    Returns
    -------
    index : int
        The variant of largest total.
    cv : CrossValidation
        Its cross-validation, with ``elpd`` (K,) the log predictive density of the variants' mixture.
    """
    if len(variants) == 1:
        return 0, variants[0]
    elpd = np.array([cv.elpd for cv in variants])  # (V, K)
    total = elpd.sum(axis=1)
    others = total[:, np.newaxis] - elpd
    weights = others - special.logsumexp(others, axis=0)
    best = int(np.argmax(total))
    return best, replace(variants[best], elpd=special.logsumexp(weights + elpd, axis=0))


def compare(a: CrossValidation, b: CrossValidation) -> Comparison:
    """Held-out comparison of ``b`` against ``a`` (fitted to the same equations)."""
    return compare_elpd(a.elpd, b.elpd)


def compare_elpd(a: np.ndarray, b: np.ndarray) -> Comparison:
    """Held-out comparison of model B against model A from their ``(K,)`` log predictive densities of the same K held-out units."""
    difference = np.asarray(b, dtype=float) - np.asarray(a, dtype=float)
    k = difference.size
    se = float(np.sqrt(k * np.var(difference, ddof=1))) if k > 1 else float("inf")
    return Comparison(delta_elpd=float(difference.sum()), se=se, n_configs=k)
