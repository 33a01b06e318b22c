"""Standard circle fits and the Cramér-Rao bounds of circle-arc models.

These are the yardsticks of the known-angle arc fit of
:mod:`bayescal.geometry.arcs`: three classical fits that ignore the joint angles
(Kåsa's algebraic fit, the "hyper" algebraic fit of Al-Sharadqah & Chernov,
and the geometric orthogonal-distance fit), and the Cramér-Rao bounds of the
circle with and without known angles, under isotropic Gaussian noise.

All functions work in the plane and in any consistent length unit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike

__all__ = [
    "CircleFit",
    "kasa_fit",
    "hyper_fit",
    "geometric_fit",
    "known_angle_crb",
    "unknown_angle_crb",
]


@dataclass(frozen=True)
class CircleFit:
    """A circle fitted to points.

    Attributes
    ----------
    centre
        Centre, shape ``(2,)``.
    radius
        Radius.
    residuals
        Signed radial residuals ``|p_i - centre| - radius``, shape ``(n,)``.
    method
        Name of the fit.
    """

    centre: np.ndarray
    radius: float
    residuals: np.ndarray
    method: str


def _points(points: ArrayLike) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 3:
        raise ValueError(f"expected at least 3 points of shape (n, 2), got shape {p.shape}")
    return p


def _circle(centre: np.ndarray, radius: float, p: np.ndarray, method: str) -> CircleFit:
    residuals = np.linalg.norm(p - centre, axis=1) - radius
    return CircleFit(np.asarray(centre, dtype=float), float(radius), residuals, method)


def kasa_fit(points: ArrayLike) -> CircleFit:
    """Kåsa's fit: least squares of ``|p - c|² - r²`` (linear in ``c`` and ``c·c - r²``).

    Biased toward small radii on short arcs; it is the one-arc case of the
    paper's concentric fit (eqs 20-24).
    """
    p = _points(points)
    mean = p.mean(axis=0)
    x = p - mean
    z = np.sum(x**2, axis=1)
    design = np.column_stack([2.0 * x, np.ones(len(x))])
    (cx, cy, d), *_ = np.linalg.lstsq(design, z, rcond=None)
    radius = np.sqrt(d + cx**2 + cy**2)
    return _circle(mean + np.array([cx, cy]), radius, p, "kasa")


def hyper_fit(points: ArrayLike) -> CircleFit:
    """The "hyper" algebraic fit (Al-Sharadqah & Chernov, 2009), free of essential bias.

    The circle ``A z + B x + C y + D = 0`` (``z = x² + y²``) minimises the
    algebraic distance under the normalisation ``Aᵀ N A = 1`` whose matrix ``N``
    removes the second-order bias; the solution is the generalized eigenvector
    of ``(M, N)`` with the smallest non-negative eigenvalue.
    """
    p = _points(points)
    mean = p.mean(axis=0)
    x, y = (p - mean).T
    z = x**2 + y**2
    design = np.column_stack([z, x, y, np.ones_like(x)])
    moments = design.T @ design / len(x)
    zbar = z.mean()
    # With centred data the hyper constraint matrix reduces to this form.
    constraint = np.array(
        [
            [8.0 * zbar, 0.0, 0.0, 2.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0, 0.0],
        ]
    )
    values, vectors = scipy.linalg.eig(moments, constraint)
    values = values.real
    candidates = np.flatnonzero(np.isfinite(values) & (values >= -1e-12 * np.abs(values[np.isfinite(values)]).max()))
    best = candidates[np.argmin(values[candidates])]
    A, B, C, D = vectors[:, best].real
    centre = mean + np.array([-B / (2 * A), -C / (2 * A)])
    radius = np.sqrt(B**2 + C**2 - 4 * A * D) / (2 * abs(A))
    return _circle(centre, radius, p, "hyper")


def geometric_fit(points: ArrayLike, start: CircleFit | None = None) -> CircleFit:
    """Geometric fit: least squares of the orthogonal distances to the circle.

    The maximum-likelihood circle under isotropic Gaussian noise when the
    points' angles are unknown.  Solved by Levenberg-Marquardt from ``start``
    (default: the hyper fit).
    """
    p = _points(points)
    start = start if start is not None else hyper_fit(p)

    def residuals(theta: np.ndarray) -> np.ndarray:
        return np.linalg.norm(p - theta[:2], axis=1) - theta[2]

    def jacobian(theta: np.ndarray) -> np.ndarray:
        diff = p - theta[:2]
        dist = np.linalg.norm(diff, axis=1)
        return np.column_stack([-diff / dist[:, None], -np.ones(len(p))])

    # imported here, as in the registration's axis fit: a campaign critique loads this module through the registration
    # and never fits a circle
    from scipy.optimize import least_squares

    theta0 = np.r_[start.centre, start.radius]
    solution = least_squares(residuals, theta0, jac=jacobian, method="lm", xtol=1e-14, ftol=1e-14)
    return _circle(solution.x[:2], abs(solution.x[2]), p, "geometric")


def known_angle_crb(angles: ArrayLike, radius: float, phi: float, sigma: float, sense: int = -1) -> np.ndarray:
    """Cramér-Rao bound of the known-angle arc model.

    The model is ``p_i = t + radius · [cos(phi + sense·q_i), sin(phi + sense·q_i)] + e_i``
    with ``e_i ~ N(0, sigma² I₂)``: eq 10 with ``R`` a rotation (``sense = +1``)
    or a reflection (``sense = -1``) by one angle.

    Parameters
    ----------
    angles
        Joint angles ``q_i`` in rad.
    radius, phi
        True radius and lever angle at q = 0 (rad).
    sigma
        Noise standard deviation per coordinate.
    sense
        +1 or -1.

    Returns
    -------
    numpy.ndarray
        Covariance bound, shape ``(4, 4)``, for ``(t_x, t_y, radius, phi)``.
    """
    if sense not in (1, -1):
        raise ValueError(f"sense must be +1 or -1, got {sense}")
    lever = phi + sense * np.asarray(angles, dtype=float)
    jac = np.zeros((2 * lever.size, 4))
    jac[0::2, 0] = 1.0
    jac[1::2, 1] = 1.0
    jac[0::2, 2] = np.cos(lever)
    jac[1::2, 2] = np.sin(lever)
    jac[0::2, 3] = -radius * np.sin(lever)
    jac[1::2, 3] = radius * np.cos(lever)
    return sigma**2 * np.linalg.inv(jac.T @ jac)


def unknown_angle_crb(point_angles: ArrayLike, sigma: float) -> np.ndarray:
    """Cramér-Rao bound of a circle whose points' angles are unknown.

    Each point's angle is a nuisance parameter; eliminating it leaves only the
    radial component of each point's information.

    Parameters
    ----------
    point_angles
        True polar angles of the points about the centre, in rad.
    sigma
        Noise standard deviation per coordinate.

    Returns
    -------
    numpy.ndarray
        Covariance bound, shape ``(3, 3)``, for ``(t_x, t_y, radius)``.
    """
    beta = np.asarray(point_angles, dtype=float)
    radial = np.column_stack([np.cos(beta), np.sin(beta), np.ones_like(beta)])
    return sigma**2 * np.linalg.inv(radial.T @ radial)
