"""The geometry posterior's density: the log-posterior with the noise σ's integrated out, and its noise integrals.

:class:`_Density` is what :class:`bayescal.geometry.posterior.GeometryPosteriorModel`
samples; with σ integrated out under a bounded prior, each marker group carries
``log[P(a, hi) - P(a, lo)]`` of a regularized incomplete gamma function, and its
σ conditional is a truncated gamma, both computed stably here.  The markers are
placed by the one marker-layout model (:mod:`bayescal.geometry.layout`).  Its
priors (:class:`GeometryPriors`) and cylinder models are defined here, below the
posterior that names them, so that the density imports nothing of it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from bayescal.geometry.arcs import LEVER_MARKER, GeometryFit, MarkerPoints
from bayescal.geometry.layout import circular_mean, cylinder_direction, lever_angle, lever_points, marker_offset

__all__ = ["CylinderModel", "GeometryPriors"]

CylinderModel = Literal["concentric", "rigid"]


@dataclass(frozen=True)
class GeometryPriors:
    """Bounds and scales of the weakly informative priors (SI).

    Attributes
    ----------
    position_sd
        Standard deviation (m) of the zero-mean normal prior on each coordinate of p2 and p0.
    length_max
        Upper bound (m) of the uniform priors on ``L`` and the marker radii.
    sigma_min, sigma_max
        Bounds (m) of the log-uniform prior on each marker group's noise σ.
    """

    position_sd: float = 10.0
    length_max: float = 10.0
    sigma_min: float = 1e-6
    sigma_max: float = 1e-2


class _Density:
    """Log-posterior of the geometry with the noise σ's integrated out (SI).

    The sampled vector holds the locations only: ``p2, L, phi, p0`` and the
    cylinder offsets (radii, and angles for the rigid model).  Given them,
    each marker group's likelihood is ``σ^-n exp(-S/2σ²)`` times factors free
    of σ (``S`` the group's residual sum of squares, ``n`` its number of
    informative coordinates), so the log-uniform prior integrates it to
    ``Γ(n/2) (S/2)^(-n/2) [P(n/2, S/2σ_min²) - P(n/2, S/2σ_max²)] / 2`` with
    ``P`` the regularized incomplete gamma function, and σ is drawn afterwards
    from its exact conditional.  For concentric markers this uses the
    large-argument form ``I0e(x) = (2π x)^(-1/2) (1 + 1/(8x) + …)`` without
    the ``1/(8x)`` term: ``x = dR/σ²`` exceeds 10⁵ for any σ below 0.5 mm at
    radii near 190 mm, so the neglected density factor is below 10⁻⁵.

    Every method takes one parameter vector ``(ndim,)`` or a batch
    ``(..., ndim)`` (``vectorized``: samplers may evaluate whole batches in
    one call).
    """

    vectorized = True

    def __init__(self, points: MarkerPoints, closed_form: GeometryFit, model: CylinderModel, priors: GeometryPriors) -> None:
        self.model = model
        self.priors = priors
        self.closed_form = closed_form
        self.sense = closed_form.lever.sense
        self.q1, self.p1 = points.of(LEVER_MARKER)
        self.cylinder_names = points.cylinder_markers
        mask = points.marker != LEVER_MARKER
        self.cq = points.q2[mask]
        self.cp = points.xyz[mask]
        self.cindex = np.array([self.cylinder_names.index(m) for m in points.marker[mask]])
        k = len(self.cylinder_names)
        self.k = k
        self.n_offset = 2 * k if model == "rigid" else k
        self.ndim = 6 + self.n_offset
        self.phi_centre = closed_form.lever.phi
        self.delta_centre = self._delta_start() if model == "rigid" else np.zeros(k)
        per_point = 2 if model == "rigid" else 1
        # Informative coordinates of each noise group: the lever marker, the cylinder markers.
        self.counts = np.array([2.0 * self.q1.size, per_point * self.cq.size])
        self._a = 0.5 * self.counts
        self._negligible = np.array([_inner_range(a, _NEGLIGIBLE_MASS) for a in self._a]).T

    def unpack(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Named parameters; ``theta`` has the parameters along its last axis."""
        k = self.k
        out = {
            "p2": theta[..., 0:2],
            "L": theta[..., 2],
            "phi": theta[..., 3],
            "p0": theta[..., 4:6],
            "radius": theta[..., 6 : 6 + k],
        }
        if self.model == "rigid":
            out["delta"] = theta[..., 6 + k : 6 + 2 * k]
        return out

    def _lever_at(self, p: dict[str, np.ndarray], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """x and y of P1 at the angles ``q`` (n,), each ``(..., n)``."""
        angle = lever_angle(p["phi"][..., None], self.sense, q)
        return lever_points(p["p2"][..., 0:1], p["p2"][..., 1:2], p["L"][..., None], angle)

    def _cylinder_direction(self, p: dict[str, np.ndarray], q: np.ndarray) -> np.ndarray:
        x, y = self._lever_at(p, q)
        return cylinder_direction(x, y, p["p0"][..., 0:1], p["p0"][..., 1:2])

    def _parts(self, p: dict[str, np.ndarray]) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...], np.ndarray | None]:
        """Residual components of P1 ``(dx, dy)`` and of the cylinder points (``(radial,)`` or ``(dx, dy)``),
        each ``(..., n)``, and the cylinder points' distances from p0 (concentric model)."""
        x, y = self._lever_at(p, self.q1)
        lever = (self.p1[:, 0] - x, self.p1[:, 1] - y)
        dx = self.cp[:, 0] - p["p0"][..., 0:1]
        dy = self.cp[:, 1] - p["p0"][..., 1:2]
        radius = p["radius"][..., self.cindex]
        if self.model == "concentric":
            distance = np.sqrt(dx * dx + dy * dy)
            return lever, (distance - radius,), distance
        angle = self._cylinder_direction(p, self.cq) + p["delta"][..., self.cindex]
        return lever, (dx - radius * np.cos(angle), dy - radius * np.sin(angle)), None

    def residuals(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residuals of P1 (``(..., n1, 2)``) and of the cylinder points (radial ``(..., m)`` or ``(..., m, 2)``)."""
        lever, cylinder, _ = self._parts(self.unpack(np.asarray(theta, dtype=float)))
        return np.stack(lever, axis=-1), cylinder[0] if len(cylinder) == 1 else np.stack(cylinder, axis=-1)

    @staticmethod
    def _sums(lever: tuple[np.ndarray, ...], cylinder: tuple[np.ndarray, ...]) -> np.ndarray:
        out = np.empty((*lever[0].shape[:-1], 2))
        out[..., 0] = sum((c * c).sum(axis=-1) for c in lever)
        out[..., 1] = sum((c * c).sum(axis=-1) for c in cylinder)
        return out

    def sums_of_squares(self, theta: np.ndarray) -> np.ndarray:
        """Residual sum of squares of each noise group (lever marker, cylinder markers): ``(..., 2)``."""
        lever, cylinder, _ = self._parts(self.unpack(np.asarray(theta, dtype=float)))
        return self._sums(lever, cylinder)

    def _gamma_bounds(self, sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        half = 0.5 * sums
        return half / self.priors.sigma_max**2, half / self.priors.sigma_min**2

    def __call__(self, theta: np.ndarray) -> float | np.ndarray:
        """Log-density (up to a constant) of one vector ``(ndim,)`` (a float) or of a batch ``(..., ndim)``."""
        theta = np.asarray(theta, dtype=float)
        p = self.unpack(theta)
        radius = p["radius"]
        inside = (
            (p["L"] > 0)
            & (p["L"] < self.priors.length_max)
            & (np.abs(p["phi"] - self.phi_centre) <= math.pi)
            & np.all((radius > 0) & (radius < self.priors.length_max), axis=-1)
        )
        if self.model == "rigid":
            inside &= np.all(np.abs(p["delta"] - self.delta_centre) <= math.pi, axis=-1)
        if theta.ndim == 1 and not inside:
            return -math.inf
        log_prior = -0.5 * ((p["p2"] ** 2).sum(axis=-1) + (p["p0"] ** 2).sum(axis=-1)) / self.priors.position_sd**2
        lever, cylinder, distance = self._parts(p)
        sums = self._sums(lever, cylinder)
        inside &= np.all(sums > 0, axis=-1)
        # Outside the support (a zero sum of squares, a negative radius) the logs below are not finite;
        # such values are replaced by -inf.
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            log_lik = (self._log_noise_mass(sums) - self._a * np.log(0.5 * sums)).sum(axis=-1)
            if distance is not None:
                log_lik -= 0.5 * np.log(distance * radius[..., self.cindex]).sum(axis=-1)
        value = np.where(inside & np.isfinite(log_lik), log_prior + log_lik, -math.inf)
        return float(value) if theta.ndim == 1 else value

    def _log_noise_mass(self, sums: np.ndarray) -> np.ndarray:
        """``log[P(a, S/2σ_min²) - P(a, S/2σ_max²)]``, the noise prior's share of each group's σ integral ``(..., 2)``.

        Zero (to rounding) where the share outside the prior is below ``_NEGLIGIBLE_MASS`` (see
        :func:`_inner_range`), as it is for residual scales well inside the prior; computed elsewhere.
        """
        lo, hi = self._gamma_bounds(sums)
        a = self._a
        out = np.zeros(sums.shape)
        needed = (lo > self._negligible[0]) | (hi < self._negligible[1])
        if needed.any():
            for group in range(a.size):
                rows = needed[..., group]
                out[..., group][rows] = _log_gamma_mass(a[group], lo[..., group][rows], hi[..., group][rows])
        return out

    def draw_sigma(self, draws: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw each group's σ from its conditional given each location draw.

        ``draws`` has shape ``(..., ndim)``; the result ``(..., 2)`` (lever, cylinder).
        """
        sums = self.sums_of_squares(draws)
        lo, hi = self._gamma_bounds(sums)
        # sigma² = S / (2u) with u ~ Gamma(n/2) truncated to the prior's bounds.
        u = _truncated_gamma(0.5 * self.counts, lo, hi, rng)
        return np.sqrt(0.5 * sums / u)

    def residuals_by_marker(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        lever, cylinder = self.residuals(theta)
        return {LEVER_MARKER: lever} | {name: cylinder[self.cindex == j] for j, name in enumerate(self.cylinder_names)}

    def _delta_start(self) -> np.ndarray:
        cf = self.closed_form
        p = {"p2": cf.lever.centre, "L": np.asarray(cf.lever.radius), "phi": np.asarray(cf.lever.phi), "p0": cf.cylinder.centre}
        centre = cf.cylinder.centre
        offset = marker_offset(self.cp[:, 0], self.cp[:, 1], centre[0], centre[1], self._cylinder_direction(p, self.cq))
        return np.array([circular_mean(offset[self.cindex == j]) for j in range(self.k)])

    def start(self) -> np.ndarray:
        """The closed-form estimate."""
        cf = self.closed_form
        radii = np.array([cf.cylinder.radii[name] for name in self.cylinder_names])
        offsets = np.r_[radii, self.delta_centre] if self.model == "rigid" else radii
        return np.r_[cf.lever.centre, cf.lever.radius, cf.lever.phi, cf.cylinder.centre, offsets]

    def scale(self, theta: np.ndarray) -> np.ndarray:
        """Approximate posterior sd at ``theta`` (Gauss-Newton), the size of the sampler's initial ball."""
        sigma = np.sqrt(self.sums_of_squares(theta) / self.counts)
        steps = 1e-7 * np.maximum(np.abs(theta), 1e-3)
        shifted = theta + np.vstack([np.zeros(theta.size), np.diag(steps)])
        lever, cylinder = self.residuals(shifted)
        whitened = np.concatenate([lever.reshape(len(shifted), -1) / sigma[0], cylinder.reshape(len(shifted), -1) / sigma[1]], axis=1)
        jac = ((whitened[1:] - whitened[0]) / steps[:, None]).T
        return np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac)))


_NEGLIGIBLE_MASS = 1e-17
"""Bound on a σ integral's share outside the noise prior below which its log, ``log(1 - share)``,
is taken as 0: the error is then below the rounding of any log-density (dimensionless)."""

_REJECTION_LIMIT = 0.5
"""Largest bound on the truncated share of a σ conditional drawn by rejection (each try is
then accepted with probability at least 1/2); beyond it σ is drawn by inverting its CDF."""


def _log_gamma_mass(a: float, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``log[P(a, hi) - P(a, lo)]`` for ``0 <= lo <= hi`` and ``a`` a positive multiple of 1/2.

    ``P`` (and ``Q = 1 - P``) are the regularized incomplete gamma functions.
    Each is taken from the form that is accurate on its side of ``x = a`` (see
    :func:`_regularized_gamma`), and the difference is formed from the small
    ones, so that no digits cancel: the exact value, to rounding, at every
    residual scale, with NumPy and the standard library only (``scipy.special``
    would add a quarter of a second to the command line's start).
    """
    p_lo, q_lo = _regularized_gamma(a, lo)
    p_hi, q_hi = _regularized_gamma(a, hi)
    mass = np.where(hi < a, p_hi - p_lo, np.where(lo >= a, q_lo - q_hi, 1.0 - p_lo - q_hi))
    with np.errstate(divide="ignore"):
        return np.log(mass)


def _regularized_gamma(a: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``P(a, x)`` and ``Q(a, x)`` for ``a`` a positive multiple of 1/2 and ``x >= 0``.

    Below ``x = a``, ``P`` from its power series
    ``x^a e^-x / Γ(a+1) · Σ_k x^k / ((a+1)…(a+k))`` (terms shrink at least as
    fast as ``x / (a+1)`` after the first); from ``x = a`` on, ``Q`` from its
    closed form, ``e^-x Σ_{k<a} x^k / k!`` for whole ``a`` and
    ``erfc(√x) + e^-x Σ_{k<a-1/2} x^(k+1/2) / Γ(k+3/2)`` for half-whole ``a``.
    The other is one minus it.
    """
    shape = np.shape(x)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    p = np.zeros(x.shape)
    low = x < a
    if low.any():
        xl = x[low]
        term = np.ones(xl.shape)
        total = np.ones(xl.shape)
        k = 0
        while np.any(term > np.finfo(float).eps * total):
            k += 1
            term = term * xl / (a + k)
            total += term
        with np.errstate(divide="ignore"):
            p[low] = np.exp(a * np.log(xl) - xl - math.lgamma(a + 1.0)) * total
    q = 1.0 - p
    high = ~low
    if high.any():
        xh = x[high]
        whole = float(a).is_integer()
        powers = np.arange(a) if whole else np.arange(a - 0.5) + 0.5
        log_terms = powers * np.log(xh)[:, None] - xh[:, None] - np.array([math.lgamma(k + 1.0) for k in powers])
        tail = np.sum(np.exp(log_terms), axis=1)
        if not whole:
            tail += np.array([math.erfc(math.sqrt(v)) for v in xh])
        q[high] = tail
        p[high] = 1.0 - tail
    return p.reshape(shape), q.reshape(shape)


def _inner_range(a: float, share: float) -> tuple[float, float]:
    """``(lo_max, hi_min)`` such that Gamma(a) puts less than ``share`` outside ``[lo, hi]``
    whenever ``lo <= lo_max`` and ``hi >= hi_min``.

    From the bounds ``P(a, x) <= x^a / Γ(a+1)`` (as ``e^-t <= 1``) and, for
    ``x > c = max(a - 1, 0)``, ``Q(a, x) <= x^(a-1) e^-x / (Γ(a) (1 - c/x))``
    (as ``(1 + u/x)^c <= e^(cu/x)``), each held to ``share / 2``; the second,
    decreasing in ``x`` from ``x = a`` on, is solved by bisection.
    """
    target = math.log(share / 2)
    lo_max = math.exp((target + math.lgamma(a + 1.0)) / a)
    c = max(a - 1.0, 0.0)

    def excess(x: float) -> float:
        return (a - 1.0) * math.log(x) - x - math.lgamma(a) - math.log1p(-c / x) - target

    left, right = a + 1.0, 2.0 * (a + 1.0)
    while excess(right) > 0:
        left, right = right, 2.0 * right
    for _ in range(60):
        middle = 0.5 * (left + right)
        left, right = (middle, right) if excess(middle) > 0 else (left, middle)
    return lo_max, right


def _truncated_gamma(a: np.ndarray, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draws of Gamma(a, 1) truncated to ``[lo, hi]``; ``a`` is ``(groups,)``, ``lo`` and ``hi`` ``(..., groups)``."""
    lo_max, hi_min = np.array([_inner_range(value, _REJECTION_LIMIT) for value in a]).T
    easy = ((lo <= lo_max) & (hi >= hi_min)).ravel()
    shape = lo.shape
    a, lo, hi = (np.broadcast_to(x, shape).ravel() for x in (a, lo, hi))
    out = np.empty(lo.size)
    pending = np.flatnonzero(easy)
    while pending.size:
        draw = rng.gamma(a[pending])
        kept = (lo[pending] <= draw) & (draw <= hi[pending])
        out[pending[kept]] = draw[kept]
        pending = pending[~kept]
    hard = ~easy
    if hard.any():
        from scipy.special import gammainc, gammaincinv

        p_lo, p_hi = gammainc(a[hard], lo[hard]), gammainc(a[hard], hi[hard])
        out[hard] = gammaincinv(a[hard], p_lo + rng.uniform(size=p_lo.size) * (p_hi - p_lo))
    return out.reshape(shape)
