"""Log-posteriors of the elastostatic deflection model.

A calibration campaign gives scalar equations (one per measured coordinate of a
marker deflection, :mod:`bayescal.inference.equations`)

    y_i = sum_j D_ij k_ij + e_i,        e_i ~ N(0, sigma_g(i)^2),

where ``D[:, j]`` is the deflection per unit compliance of joint j (the columns
of eq 31, Klimchik et al.) and ``g(i)`` the noise group of the equation (the
measurement axis by default).  Two parametrisations of the joint-2 compliance
are used, both :class:`~bayescal.sampling.gibbs.ConditionallyLinear` models:

* per angle (eq 30): one free compliance ``k2@q2`` for each distinct q2 angle;
* compensated (eq 8): ``k2(q2) = 1 / (C(q2) @ w)`` with the regressor C of
  eq 35 and ``w = [K_theta2^0, K_c, s0 * K_c]``, so that the joint-2 stiffness
  is ``K_theta2^0 + K_c a L eta(q2; s0)``.

Priors (stated here once, used by every sampler): compliances, ``K_theta2^0``
and ``K_c`` flat on the positive half-line (the compensated model moves
``log K_c``, with the Jacobian of that flat prior); ``s0`` flat between 0 and
``a + L``, the longest the spring can be (an unbounded flat prior would leave
the posterior improper whenever the data do not exclude ``K_c = 0``, where s0
has no effect); each noise variance Jeffreys ``p(sigma^2) ∝ 1/sigma^2`` (flat
in ``log sigma``); the compensator geometry ``(L, a_x, a_y, phi)`` Gaussian
(:class:`~bayescal.inference.priors.GeometryPrior`).  Everything is in SI.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.parameters import GEOMETRY_PARAMETERS
from bayescal.inference.priors import GeometryPrior
from bayescal.robot.compensator import stiffness_regressor
from bayescal.sampling.gibbs import ConditionallyLinear

__all__ = ["CompensatorBlock", "per_angle_posterior", "compensated_posterior", "SPRING"]

SPRING = ("K_theta2_ref", "log_K_c", "s0")
"""The compensated model's spring coordinates, in order: joint 2's equivalent stiffness at the reference
angle (N·m/rad), log K_c (log N/m), s0 (m)."""
"""The compensator geometry's coordinates, in order: m, m, m, rad."""


@dataclass(frozen=True)
class CompensatorBlock:
    """The joint-2 compliance at each campaign angle as a function of the spring and geometry (eq 8).

    ``z = [K_ref, log K_c, s0]`` followed by ``[L, a_x, a_y, phi]`` when the
    geometry prior is not fixed; a block of
    :class:`~bayescal.sampling.gibbs.ConditionallyLinear`.  ``K_ref`` is joint
    2's equivalent stiffness (eq 8) at the reference angle ``q_ref``, so that
    ``K_theta2^0 = K_ref - K_c a L eta(q_ref; s0)``.  The data determine the
    equivalent stiffness far better than its split between the joint and a
    spring that changes it by a fraction of a percent: in ``(K_theta2^0, K_c)``
    the posterior is a narrow curved ridge, in ``(K_ref, log K_c)`` nearly a
    product, which is what a Metropolis proposal needs.

    With ``static`` (the exact model), the block also sets the coefficients
    ``u(z) = [K_c - K_c*, K_c s0 - (K_c s0)*, gravity_scale - g*]`` of the
    columns ``W`` that linearise the exact model's correction about the
    spring and link-mass scale ``static = [K_c*, (K_c s0)*, g*]``: the
    compensator's static torque, linear in ``K_c`` and ``K_c s0`` (eq 7), and
    the arm's weight set the sag under which the loads act.  ``z`` then holds
    ``gravity_scale`` after ``s0``, a factor on every link's mass with a
    Gaussian prior of mean 1 and sd ``gravity_sd``.
    """

    q2: np.ndarray
    geometry: GeometryPrior
    q_ref: float
    static: np.ndarray | None = None
    gravity_sd: float = 0.0

    @property
    def ndim(self) -> int:
        return self.n_adapted + (0 if self.geometry.fixed else len(GEOMETRY_PARAMETERS))

    @property
    def n_adapted(self) -> int:
        return len(SPRING) + (self.static is not None)

    @property
    def prior_mean(self) -> np.ndarray:
        return self.geometry.mean

    @property
    def prior_cov(self) -> np.ndarray:
        return self.geometry.cov

    def _geometry(self, z: np.ndarray) -> np.ndarray:
        a = self.n_adapted
        return np.broadcast_to(self.geometry.mean, (z.shape[0], 4)) if self.geometry.fixed else z[:, a : a + 4]

    def gravity_scale(self, z: np.ndarray) -> np.ndarray | None:
        """``(c,)`` the link weights' scale, or None when the block has no static channel."""
        return None if self.static is None else z[:, len(SPRING)]

    def shift(self, z: np.ndarray) -> np.ndarray:
        """``(c, 3)`` coefficients ``u(z)`` of the static columns (``(c, 0)`` without them)."""
        if self.static is None:
            return np.zeros((z.shape[0], 0))
        K_c = np.exp(z[:, 1])
        return np.column_stack([K_c - self.static[0], K_c * z[:, 2] - self.static[1], z[:, len(SPRING)] - self.static[2]])

    def _regressor(self, z: np.ndarray, q2: np.ndarray) -> np.ndarray:
        """``(c|1, m + 1, 3)`` eq-35 rows at ``q2`` and, last, at ``q_ref``."""
        if self.geometry.fixed:
            return (self._fixed_regressor if q2 is self.q2 else stiffness_regressor(np.append(q2, self.q_ref), *self.geometry.mean))[None]
        g = self._geometry(z)
        return stiffness_regressor(np.append(q2, self.q_ref)[None, :], *(g[:, i, None] for i in range(4)))

    def stiffness(self, z: np.ndarray, q2: np.ndarray | None = None) -> np.ndarray:
        """``(c, m)`` equivalent joint-2 stiffness (N·m/rad) at the angles ``q2`` (default: the campaign's)."""
        return self._stiffness(z, self._regressor(z, self.q2 if q2 is None else np.asarray(q2, dtype=float)))

    def spring(self, z: np.ndarray) -> np.ndarray:
        """``(c, 3)`` ``[K_theta2^0 (N·m/rad), K_c (N/m), s0 (m)]`` at ``(c, ndim)`` points."""
        return self._spring(z, self._regressor(z, self.q2))

    @staticmethod
    def _stiffness(z: np.ndarray, C: np.ndarray) -> np.ndarray:
        change = C[..., :-1, 1:] - C[..., -1:, 1:]
        return z[:, :1] + np.exp(z[:, 1])[:, None] * (change[..., 0] + change[..., 1] * z[:, 2:3])

    @staticmethod
    def _spring(z: np.ndarray, C: np.ndarray) -> np.ndarray:
        reference = C[..., -1, :]
        K_c = np.exp(z[:, 1])
        return np.column_stack([z[:, 0] - K_c * (reference[..., 1] + reference[..., 2] * z[:, 2]), K_c, z[:, 2]])

    def coordinates(self, spring: np.ndarray) -> np.ndarray:
        """``[K_ref, log K_c, s0]`` of a spring ``[K_theta2^0, K_c, s0]`` at the geometry prior's mean."""
        K0, K_c, s0 = spring
        C = stiffness_regressor(self.q_ref, *self.geometry.mean)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.array([C @ [K0, K_c, s0 * K_c], np.log(K_c), s0])

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(c, m)`` joint-2 compliances (rad/(N·m)) and ``(c,)`` log prior at ``(c, ndim)`` points.

        The compliance is ``nan`` and the log prior ``-inf`` outside the support
        (``K_theta2^0 > 0``, ``0 < s0 < a + L``) or where the stiffness is not
        positive; the log prior is ``log K_c`` (the Jacobian of K_c's flat prior)
        plus the geometry's and the gravity scale's log densities.
        """
        C, longest, log_prior = self._geometry_terms(z)
        log_prior = log_prior + z[:, 1]
        if self.static is not None:
            log_prior = log_prior - 0.5 * ((z[:, len(SPRING)] - 1.0) / self.gravity_sd) ** 2
        total = self._stiffness(z, C)
        ok = (self._spring(z, C)[:, 0] > 0) & (z[:, 2] > 0) & (z[:, 2] < longest)
        positive = ok[:, None] & (total > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(positive, 1.0 / total, np.nan), np.where(ok, log_prior, -np.inf)

    def _geometry_terms(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray | float, np.ndarray | float]:
        """The eq-35 rows at the campaign's angles, the spring's longest length and the geometry's log prior at ``z``."""
        if self.geometry.fixed:
            return self._fixed_regressor[None], self._longest, 0.0
        g = self._geometry(z)
        return self._regressor(z, self.q2), np.hypot(g[:, 1], g[:, 2]) + g[:, 0], self.geometry.log_density(g)

    @cached_property
    def _fixed_regressor(self) -> np.ndarray:
        return stiffness_regressor(np.append(self.q2, self.q_ref), *self.geometry.mean)

    @cached_property
    def _longest(self) -> float:
        L, a_x, a_y = self.geometry.mean[:3]
        return float(np.hypot(a_x, a_y) + L)


def per_angle_posterior(equations: DeflectionEquations, free: np.ndarray) -> ConditionallyLinear:
    """Posterior of eq 30 with one joint-2 compliance per angle: ``theta = [compliances of the free columns, log sigma]``."""
    return ConditionallyLinear(
        y=equations.y,
        X=equations.per_angle_design(free),
        group=equations.group,
        n_groups=len(equations.group_names),
    )


def compensated_posterior(
    equations: DeflectionEquations,
    joints: tuple[int, ...],
    geometry: GeometryPrior,
    static: tuple[np.ndarray, np.ndarray] | None = None,
    gravity_sd: float = 0.0,
) -> ConditionallyLinear:
    """Posterior with the compensator's joint-2 stiffness (eq 8).

    ``theta``: the compliances of ``joints`` (0-based, joint 2 excluded), then
    ``K_ref, log K_c, s0`` (:class:`CompensatorBlock`, reference angle the campaign's median q2), then
    ``gravity_scale`` with ``static``, then the geometry ``L, a_x, a_y, phi`` unless
    its prior is fixed, then ``log sigma`` per noise group.  ``static`` is the
    linearisation point ``[K_c, K_c s0, gravity_scale]`` (N/m, N, 1) and the ``(n, 3)`` columns
    ``W`` of the exact model's correction (:class:`CompensatorBlock`).
    """
    if equations.joint in joints:
        raise ValueError("the compensated joint is described by the compensator parameters, not by a free compliance")
    return ConditionallyLinear(
        y=equations.y,
        X=equations.design[:, list(joints)],
        group=equations.group,
        n_groups=len(equations.group_names),
        b=equations.design[:, equations.joint],
        level=equations.angle,
        block=CompensatorBlock(
            equations.compensated_angles,
            geometry,
            q_ref=float(np.median(equations.compensated_angles)),
            static=None if static is None else static[0],
            gravity_sd=gravity_sd,
        ),
        W=None if static is None else static[1],
    )
