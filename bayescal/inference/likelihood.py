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
from bayescal.robot.compensator import law_on
from bayescal.robot.laws import CompensatorLaw
from bayescal.sampling.gibbs import ConditionallyLinear

__all__ = ["CompensatorBlock", "per_angle_posterior", "compensated_posterior"]


@dataclass(frozen=True)
class CompensatorBlock:
    """The compensated joint's compliance at each campaign angle as a function of its law and geometry (eq 8).

    ``z = [K_ref, *law coordinates]`` (``[K_ref, log K_c, s0]`` for the spring)
    followed by ``[L, a_x, a_y, phi]`` when the geometry prior is not fixed; a
    block of :class:`~bayescal.sampling.gibbs.ConditionallyLinear`.  ``K_ref``
    is the joint's equivalent stiffness (eq 8) at the reference angle
    ``q_ref``, so that ``K_theta2^0 = K_ref - dM_c/dq(q_ref)``.  The data
    determine the equivalent stiffness far better than its split between the
    joint and a compensator that changes it by a fraction of a percent: in
    ``(K_theta2^0, K_c)`` the posterior is a narrow curved ridge, in ``(K_ref,
    log K_c)`` nearly a product, which is what a Metropolis proposal needs.
    The law (:class:`~bayescal.robot.laws.CompensatorLaw`, the spring when None)
    says what its coordinates are, their priors and their support.

    With ``static`` (the exact model), the block also sets the coefficients
    ``u(z) = [static coordinates - their linearisation point, gravity_scale - g*]``
    of the columns ``W`` that linearise the exact model's correction about the
    law's static coordinates and link-mass scale ``static`` (for the spring
    ``[K_c*, (K_c s0)*, g*]``: its static torque is linear in ``K_c`` and
    ``K_c s0``, eq 7), and the arm's weight set the sag under which the loads
    act.  ``z`` then holds ``gravity_scale`` after the law's coordinates, a
    factor on every link's mass with a Gaussian prior of mean 1 and sd
    ``gravity_sd``.
    """

    q2: np.ndarray
    geometry: GeometryPrior
    q_ref: float
    static: np.ndarray | None = None
    gravity_sd: float = 0.0
    law: CompensatorLaw | None = None

    def __post_init__(self) -> None:
        # The law on the geometry prior's mean: a block the caller built without one holds the spring.
        object.__setattr__(self, "law", law_on(self.law, self.geometry.mean, None if self.law is None else self.law.values))

    @property
    def ndim(self) -> int:
        return self.n_adapted + (0 if self.geometry.fixed else len(GEOMETRY_PARAMETERS))

    @property
    def n_law(self) -> int:
        """The law's coordinates."""
        return len(self.law.COORDINATES)

    @property
    def n_adapted(self) -> int:
        return 1 + self.n_law + (self.static is not None)

    @property
    def prior_mean(self) -> np.ndarray:
        return self.geometry.mean

    @property
    def prior_cov(self) -> np.ndarray:
        return self.geometry.cov

    def _geometry(self, z: np.ndarray) -> np.ndarray:
        a = self.n_adapted
        return np.broadcast_to(self.geometry.mean, (z.shape[0], 4)) if self.geometry.fixed else z[:, a : a + 4]

    def _law_z(self, z: np.ndarray) -> np.ndarray:
        return z[:, 1 : 1 + self.n_law]

    def gravity_scale(self, z: np.ndarray) -> np.ndarray | None:
        """``(c,)`` the link weights' scale, or None when the block has no static channel."""
        return None if self.static is None else z[:, 1 + self.n_law]

    def shift(self, z: np.ndarray) -> np.ndarray:
        """``(c, p + 1)`` coefficients ``u(z)`` of the static columns (``(c, 0)`` without them)."""
        if self.static is None:
            return np.zeros((z.shape[0], 0))
        u = self.law.static_point(self.law.block_values(self._law_z(z)))
        return np.column_stack([u - self.static[:-1], z[:, 1 + self.n_law] - self.static[-1]])

    def _regressor(self, z: np.ndarray, q2: np.ndarray) -> np.ndarray:
        """``(c|1, m + 1, r)`` the law's rows at ``q2`` and, last, at ``q_ref``."""
        if self.geometry.fixed:
            return self._fixed_regressor if q2 is self.q2 else self.law.block_rows(np.append(q2, self.q_ref), None)
        return self.law.block_rows(np.append(q2, self.q_ref), self._geometry(z))

    def stiffness(self, z: np.ndarray, q2: np.ndarray | None = None) -> np.ndarray:
        """``(c, m)`` equivalent stiffness of the compensated joint (N·m/rad) at the angles ``q2`` (default: the campaign's)."""
        return self._stiffness(z, self._regressor(z, self.q2 if q2 is None else np.asarray(q2, dtype=float)))

    def spring(self, z: np.ndarray) -> np.ndarray:
        """``(c, 1 + p)`` ``[K_theta2^0 (N·m/rad), *law values]`` (``K_c`` N/m, ``s0`` m for the spring) at ``(c, ndim)`` points."""
        return self._spring(z, self._regressor(z, self.q2))

    def _stiffness(self, z: np.ndarray, C: np.ndarray) -> np.ndarray:
        return z[:, :1] + self.law.block_change(self._law_z(z), C)

    def _spring(self, z: np.ndarray, C: np.ndarray) -> np.ndarray:
        law_z = self._law_z(z)
        return np.column_stack([z[:, 0] - self.law.block_reference(law_z, C), self.law.block_values(law_z)])

    def coordinates(self, spring: np.ndarray) -> np.ndarray:
        """``[K_ref, *law coordinates]`` of ``[K_theta2^0, *law values]`` at the geometry prior's mean."""
        K0, values = spring[0], spring[1:]
        C = self.law.regressor(self.q_ref)
        return np.concatenate([[C @ [K0, *self.law.linear(values)]], self.law.block_coordinates(values)])

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(c, m)`` compliances of the compensated joint (rad/(N·m)) and ``(c,)`` log prior at ``(c, ndim)`` points.

        The compliance is ``nan`` and the log prior ``-inf`` outside the support
        (``K_theta2^0 > 0`` and the law's, :meth:`~bayescal.robot.laws.CompensatorLaw.block_inside`) or where the
        stiffness is not positive; the log prior is the law's Jacobian (``log K_c`` for the spring: K_c's flat
        prior) plus the geometry's and the gravity scale's log densities.
        """
        C, geometry, log_prior = self._geometry_terms(z)
        law_z = self._law_z(z)
        log_prior = log_prior + self.law.block_log_jacobian(law_z)
        if self.static is not None:
            log_prior = log_prior - 0.5 * ((z[:, 1 + self.n_law] - 1.0) / self.gravity_sd) ** 2
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            total = self._stiffness(z, C)
            ok = (self._spring(z, C)[:, 0] > 0) & self.law.block_inside(law_z, geometry)
        positive = ok[:, None] & (total > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(positive, 1.0 / total, np.nan), np.where(ok, log_prior, -np.inf)

    def _geometry_terms(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray | float]:
        """The law's rows at the campaign's angles, the ``(c|1, 4)`` geometry and its log prior at ``z``."""
        if self.geometry.fixed:
            return self._fixed_regressor, self.geometry.mean[None, :], 0.0
        g = self._geometry(z)
        return self._regressor(z, self.q2), g, self.geometry.log_density(g)

    @cached_property
    def _fixed_regressor(self) -> np.ndarray:
        return self.law.block_rows(np.append(self.q2, self.q_ref), None)


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
    law: CompensatorLaw | None = None,
) -> ConditionallyLinear:
    """Posterior with the compensator's joint-2 stiffness (eq 8).

    ``theta``: the compliances of ``joints`` (0-based, joint 2 excluded), then
    ``K_ref`` and the coordinates of the compensator's ``law`` (``log K_c, s0`` for the spring, None's;
    :class:`CompensatorBlock`, reference angle the campaign's median q2), then
    ``gravity_scale`` with ``static``, then the geometry ``L, a_x, a_y, phi`` unless
    its prior is fixed, then ``log sigma`` per noise group.  ``static`` is the
    linearisation point ``[*static coordinates of the law, gravity_scale]`` (``K_c, K_c s0`` in N/m, N for the
    spring) and the ``(n, p + 1)`` columns
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
            law=law,
        ),
        W=None if static is None else static[1],
    )
