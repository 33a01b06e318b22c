"""The axis fit's covariance clustered by swept angle, its small-sample degrees of freedom and intervals.

A sweep's readings of one angle share the joint's wobble and transmission error there, so the fit's
covariance is a cluster-robust (sandwich) one, the readings clustered by angle, bias-reduced by Bell and
McCaffrey's ``A_g = (I - H_gg)^-½`` (exact in expectation for independent noise of the stated law).  With
the 5-12 angles of a sweep that estimate is itself noisy: a component's error over its sd has Student-t tails,
with Bell and McCaffrey's Satterthwaite degrees of freedom (Imbens and Kolesár, 2016)

    ν = tr(M)² / tr(M²),   M_gh = w_gᵀ w_h,   w_g = (I - H)_{·g} A_g J_g (JᵀJ)⁻¹ c,

for the contrast ``c`` (the sandwich's variance of ``cᵀx`` is ``Σ_g (w_gᵀ ε)²`` for whitened noise ``ε``).
An interval with the normal's ``±kσ`` coverage is then ``±t_ν(Φ(k)) sd`` (:func:`interval_factor`).

Where the tracker's law stands in for the sandwich (a direction it does not see, :func:`unseen_at_floor`), or the
variance is a sum of several axes' (a frame), the degrees of freedom follow Welch and Satterthwaite's rule
(:func:`combined_dof`): the variance's own variance is the sandwiches', ``2 v_i² / ν_i`` each, the law being known.
"""

from __future__ import annotations

import numpy as np

__all__ = ["clustered_covariance", "sandwich_dof", "combined_dof", "interval_factor", "unseen_at_floor"]

_UNSEEN = 1e-6
"""The sandwich's variance over the tracker law's below which it does not see a direction: a sweep of fewer angles
than the axis has parameters leaves the sandwich singular (round-off, 1e-16), while a scaled χ² with a sweep's
2 (3) degrees of freedom falls below 1e-6 of its mean with probability 1e-6 (1e-9)."""
_LEVERAGE_FLOOR = 1e-9
"""Smallest eigenvalue of ``I - H_gg`` (dimensionless) taken as a residual direction: below it, round-off of a
direction the fit reproduces exactly."""


def clustered_covariance(jac: np.ndarray, residual: np.ndarray, bread: np.ndarray, cluster: np.ndarray):
    """The bias-reduced sandwich covariance of least-squares parameters and its degrees-of-freedom kernel.

    Parameters
    ----------
    jac
        (3n, p) Jacobian of the whitened residuals at the optimum.
    residual
        (3n,) whitened residuals.
    bread
        (p, p) ``(JᵀJ)⁻¹``.
    cluster
        (n,) each reading's cluster (its swept angle's number); its three coordinates share it.

    Returns
    -------
    cov
        (p, p) ``B (Σ_g J_gᵀ A_g r_g r_gᵀ A_g J_g) B``.
    kernel
        (G, 3n, p) per cluster ``(I - H)_{·g} A_g J_g B``: a contrast ``c`` (p,) gives the columns ``kernel @ c``
        of :func:`sandwich_dof`.
    """
    rows = np.repeat(cluster, 3)
    residual_maker = np.eye(jac.shape[0]) - jac @ bread @ jac.T
    meat = np.zeros_like(bread)
    kernel = []
    for g in np.unique(rows):
        Jg = jac[rows == g]
        values, vectors = np.linalg.eigh(np.eye(Jg.shape[0]) - Jg @ bread @ Jg.T)
        # A cluster the model fits exactly (leverage 1) carries no information on its own error: left out.
        shrink = vectors @ np.diag(np.where(values > _LEVERAGE_FLOOR, values, np.inf) ** -0.5) @ vectors.T
        score = Jg.T @ shrink @ residual[rows == g]
        meat += np.outer(score, score)
        kernel.append(residual_maker[rows == g].T @ shrink @ Jg @ bread)
    return bread @ meat @ bread, np.array(kernel)


def sandwich_dof(kernel: np.ndarray, contrast: np.ndarray) -> float:
    """Bell and McCaffrey's degrees of freedom of the sandwich's variance of ``contrast @ x``.

    ``kernel`` (G, m, q) from :func:`clustered_covariance` (its last axis possibly mapped to other parameters),
    ``contrast`` (q,).  ``tr(M)² / tr(M²)`` of the (G, G) ``M = W Wᵀ``, ``W = kernel @ contrast``: G - 1 for a mean
    over G balanced clusters; ``inf`` for a contrast the sandwich does not see.
    """
    w = kernel @ contrast
    m = w @ w.T
    square = float(np.sum(m * m))
    return float(np.trace(m) ** 2 / square) if square > 0 else np.inf


def combined_dof(variance: float, parts) -> float:
    """Welch-Satterthwaite degrees of freedom of a variance ``variance`` whose random parts are sandwiches.

    ``parts``: (sandwich variance, its degrees of freedom) of each independent part; the rest of ``variance``
    (a floor known exactly) adds none of its own noise.  ``inf`` when no part varies.
    """
    noise = sum(v * v / dof for v, dof in parts if v > 0 and np.isfinite(dof))
    return float(variance * variance / noise) if noise > 0 else np.inf


def interval_factor(k: float, dof) -> np.ndarray:
    """Half-width, in sds, of the Student-t interval with the normal's ``±k sd`` coverage; ``k`` for ``dof = inf``."""
    from scipy.stats import norm, t

    return np.where(np.isfinite(dof), t.ppf(norm.cdf(k), np.where(np.isfinite(dof), dof, 1.0)), k)


def unseen_at_floor(cov: np.ndarray, floor: np.ndarray) -> np.ndarray:
    """``cov`` with ``floor`` in the directions it does not see: its variance there below :data:`_UNSEEN` of the floor's.

    Both (q, q), ``floor`` positive definite; compared in the floor's metric (generalised eigen-directions).
    """
    root = np.linalg.cholesky(floor)
    inverse = np.linalg.inv(root)
    values, vectors = np.linalg.eigh(inverse @ cov @ inverse.T)
    values = np.where(values < _UNSEEN, 1.0, values)
    return root @ vectors @ np.diag(values) @ vectors.T @ root.T
