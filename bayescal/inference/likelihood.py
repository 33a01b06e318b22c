"""Log-posteriors of the elastostatic deflection model.

A calibration campaign gives scalar equations (one per measured coordinate of a
marker deflection)

    y_i = sum_j D_ij k_ij + e_i,        e_i ~ N(0, sigma_g(i)^2),

where ``D[:, j]`` is the deflection per unit compliance of joint j (the columns
of eq 31, Klimchik et al.) and ``g(i)`` the noise group of the equation (the
measurement axis by default).  Two parametrisations of the joint-2 compliance
are used:

* per angle (eq 30): one free compliance ``k2@q2`` for each distinct q2 angle;
* compensated (eq 8): ``k2(q2) = 1 / (C(q2) @ w)`` with the regressor C of
  eq 35 and ``w = [K_theta2^0, K_c, s0 * K_c]``, so that the joint-2 stiffness
  is ``K_theta2^0 + K_c a L eta(q2; s0)``.

Priors (stated here once, used by every sampler): compliances, ``K_theta2^0``
and ``K_c`` flat on the positive half-line; ``s0`` flat between 0 and
``a + L``, the longest the spring can be (an unbounded flat prior would leave
the posterior improper whenever the data do not exclude ``K_c = 0``, where s0
has no effect); each noise variance Jeffreys
``p(sigma^2) ∝ 1/sigma^2`` (flat in ``log sigma``); the compensator geometry
``(L, a_x, a_y, phi)`` Gaussian (:class:`GeometryPrior`).  Everything is in SI.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.robot.compensator import CompensatorGeometry

__all__ = [
    "DeflectionEquations",
    "GeometryPrior",
    "PerAnglePosterior",
    "CompensatedPosterior",
    "compensator_regressor",
    "in_support",
]



def compensator_regressor(geometry: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Rows C(q2) of eq 35 (Klimchik et al.) for the compensator geometry ``[L, a_x, a_y, phi]`` (m, rad).

    ``C(q2) @ [K_theta2^0, K_c, s0 * K_c]`` is the joint-2 stiffness (N·m/rad).
    """
    L, a_x, a_y, phi = (float(v) for v in geometry)
    return CompensatorGeometry(L=L, a_x=a_x, a_y=a_y, phi=phi).regressor(np.asarray(q2, dtype=float))


@dataclass(frozen=True)
class DeflectionEquations:
    """The scalar equations of a campaign, linear in the joint compliances.

    Parameters
    ----------
    y
        Measured deflection components (m), shape ``(n,)``.
    design
        ``(n, 6)``: column j is the deflection per unit compliance of joint j
        (m per rad/(N·m)).
    angle
        ``(n,)`` index into ``q2`` of each equation's joint-2 angle.
    q2
        The distinct joint-2 angles (rad), shape ``(m,)``.
    group
        ``(n,)`` noise group of each equation (index into ``group_names``).
    group_names
        Names of the noise groups, e.g. ``("x", "y", "z")``.
    scale
        ``(n,)`` known relative noise sd of each equation (e.g. from the
        tracker's distance-dependent error); the group's unknown sigma
        multiplies it.  None: all equal.
    """

    y: np.ndarray
    design: np.ndarray
    angle: np.ndarray
    q2: np.ndarray
    group: np.ndarray
    group_names: tuple[str, ...]
    scale: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        if self.design.shape != (n, 6) or self.angle.shape != (n,) or self.group.shape != (n,):
            raise ValueError("y, design, angle and group must describe the same equations")
        if self.angle.max(initial=0) >= self.q2.size or self.group.max(initial=0) >= len(self.group_names):
            raise ValueError("angle or group index out of range")

    def whitened(self) -> DeflectionEquations:
        """The same equations divided by their relative noise sd, so that noise is equal within a group."""
        if self.scale is None:
            return self
        return replace(self, y=self.y / self.scale, design=self.design / self.scale[:, None], scale=None)

    @property
    def n(self) -> int:
        """Number of scalar equations."""
        return int(self.y.shape[0])

    def per_angle_columns(self) -> list[tuple[int, int | None]]:
        """``(joint, angle)`` of each per-angle column: joint 2 once per angle, the others once."""
        columns: list[tuple[int, int | None]] = []
        for joint in range(6):
            if joint == COMPENSATED_JOINT:
                columns.extend((COMPENSATED_JOINT, a) for a in range(self.q2.size))
            else:
                columns.append((joint, None))
        return columns

    def per_angle_design(self) -> np.ndarray:
        """The design of eq 30 with one joint-2 column per distinct q2 angle, ``(n, 5 + m)``."""
        columns = []
        for joint, angle in self.per_angle_columns():
            column = self.design[:, joint].copy()
            if angle is not None:
                column[self.angle != angle] = 0.0
            columns.append(column)
        return np.column_stack(columns)


@dataclass(frozen=True)
class GeometryPrior:
    """Gaussian prior of the compensator geometry ``[L, a_x, a_y, phi]`` (m, m, m, rad).

    A zero covariance fixes the geometry at ``mean``.
    """

    mean: np.ndarray
    cov: np.ndarray
    source: str = ""

    @property
    def fixed(self) -> bool:
        """True when the geometry is not sampled."""
        return not np.any(self.cov)

    @classmethod
    def from_draws(cls, draws: np.ndarray, source: str = "") -> GeometryPrior:
        """Mean and covariance of geometry draws ``(n, 4)`` (e.g. a geometry posterior)."""
        draws = np.asarray(draws, dtype=float)
        return cls(mean=draws.mean(axis=0), cov=np.cov(draws, rowvar=False), source=source)

    @cached_property
    def _precision(self) -> np.ndarray:
        return np.linalg.inv(self.cov)

    def log_density(self, geometry: np.ndarray) -> float:
        """Log-density up to a constant (0 when fixed)."""
        if self.fixed:
            return 0.0
        d = geometry - self.mean
        return float(-0.5 * d @ self._precision @ d)


def _noise_log_likelihood(residual: np.ndarray, group: np.ndarray, log_sigma: np.ndarray) -> float:
    ssr = np.bincount(group, weights=residual**2, minlength=log_sigma.size)
    counts = np.bincount(group, minlength=log_sigma.size)
    return float(np.sum(-counts * log_sigma - 0.5 * ssr * np.exp(-2.0 * log_sigma)))


@dataclass(frozen=True)
class PerAnglePosterior:
    """Posterior of the per-angle linear model (eq 30) with unknown noise per group.

    Parameter vector: the compliances of the columns in ``free`` (a mask over
    :meth:`DeflectionEquations.per_angle_columns`), then ``log sigma`` per group.
    """

    equations: DeflectionEquations
    free: np.ndarray
    design: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "design", self.equations.per_angle_design()[:, self.free])

    @property
    def n_linear(self) -> int:
        """Number of compliances."""
        return int(self.design.shape[1])

    def log_prob(self, theta: np.ndarray) -> float:
        """Log-posterior density up to a constant; ``-inf`` outside the support."""
        k = theta[: self.n_linear]
        if np.any(k <= 0):
            return -np.inf
        residual = self.equations.y - self.design @ k
        return _noise_log_likelihood(residual, self.equations.group, theta[self.n_linear :])


def in_support(stiffness: np.ndarray, geometry: np.ndarray) -> bool:
    """Whether ``[K_theta2^0, K_c, s0]`` lies in the prior's support for geometry ``[L, a_x, a_y, phi]``."""
    K0, Kc, s0 = stiffness
    L, a_x, a_y = geometry[:3]
    return bool(K0 > 0 and Kc > 0 and 0 < s0 < np.hypot(a_x, a_y) + L)


@dataclass(frozen=True)
class CompensatedPosterior:
    """Posterior of the model with the compensator's joint-2 stiffness (eq 8).

    Parameter vector ``theta``: the compliances of the joints in ``joints``
    (0-based, joint 2 excluded), then ``K_theta2^0, K_c, s0``, then the geometry
    ``L, a_x, a_y, phi`` unless the geometry prior is fixed, then ``log sigma``
    per noise group.
    """

    equations: DeflectionEquations
    joints: tuple[int, ...]
    geometry: GeometryPrior

    def __post_init__(self) -> None:
        if COMPENSATED_JOINT in self.joints:
            raise ValueError("joint 2 is described by the compensator parameters, not by a free compliance")

    @property
    def n_linear(self) -> int:
        """Number of free compliances (joints other than 2)."""
        return len(self.joints)

    @property
    def n_geometry(self) -> int:
        """Number of sampled geometry parameters (0 or 4)."""
        return 0 if self.geometry.fixed else 4

    @property
    def ndim(self) -> int:
        """Length of ``theta``."""
        return self.n_linear + 3 + self.n_geometry + len(self.equations.group_names)

    def names(self) -> list[str]:
        """Names of the entries of ``theta``."""
        geometry = ["L", "a_x", "a_y", "phi"] if self.n_geometry else []
        return (
            [f"k{j + 1}" for j in self.joints]
            + ["K_theta2_0", "K_c", "s0"]
            + geometry
            + [f"log_sigma_{g}" for g in self.equations.group_names]
        )

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(compliances, [K_theta2^0, K_c, s0], geometry, log_sigma)`` from ``theta``."""
        p = self.n_linear
        k = theta[:p]
        stiffness = theta[p : p + 3]
        geometry = theta[p + 3 : p + 3 + self.n_geometry] if self.n_geometry else self.geometry.mean
        return k, stiffness, geometry, theta[p + 3 + self.n_geometry :]

    def joint2_compliance(self, stiffness: np.ndarray, geometry: np.ndarray) -> np.ndarray:
        """Equivalent joint-2 compliance ``1 / (K_theta2^0 + K_c a L eta)`` at each angle (rad/(N·m)).

        ``nan`` where the equivalent stiffness is not positive.
        """
        K0, Kc, s0 = stiffness
        total = compensator_regressor(geometry, self.equations.q2) @ np.array([K0, Kc, s0 * Kc])
        with np.errstate(divide="ignore"):
            return np.where(total > 0, 1.0 / total, np.nan)

    def joint2_deflection(self, stiffness: np.ndarray, geometry: np.ndarray) -> np.ndarray | None:
        """Joint 2's contribution to each equation, or None outside the support."""
        k2 = self.joint2_compliance(stiffness, geometry)
        if not np.all(np.isfinite(k2)):
            return None
        return self.equations.design[:, COMPENSATED_JOINT] * k2[self.equations.angle]

    def log_prob(self, theta: np.ndarray) -> float:
        """Log-posterior density up to a constant; ``-inf`` outside the support."""
        k, stiffness, geometry, log_sigma = self.split(np.asarray(theta, dtype=float))
        if np.any(k <= 0) or not in_support(stiffness, geometry):
            return -np.inf
        joint2 = self.joint2_deflection(stiffness, geometry)
        if joint2 is None:
            return -np.inf
        residual = self.equations.y - joint2 - self.equations.design[:, list(self.joints)] @ k
        return _noise_log_likelihood(residual, self.equations.group, log_sigma) + self.geometry.log_density(geometry)

    def start(self, k: np.ndarray, stiffness: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """A parameter vector from its parts (geometry at the prior mean)."""
        geometry = self.geometry.mean if self.n_geometry else np.empty(0)
        return np.concatenate([k, stiffness, geometry, np.log(sigma)])

