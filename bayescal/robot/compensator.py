"""The spring gravity compensator of joint 2: its geometry and its mechanics (eqs 4-9, 35).

Conventions (SI throughout: m, rad, N, N·m, N/m).  The compensator lives in a
plane with coordinates (X, Y): X horizontal along the upper arm at q2 = 0,
pointing away from the base, Y vertical up, as the laser-tracker frame of
Klimchik et al., Table I.  P2 is on the joint-2 axis, P0 is the fixed pivot of
the compensator on link 1 and P1 its pivot on link 2.

* ``L = |P1 P2|``, the lever on link 2;
* ``(a_x, a_y)`` the projections of ``p2 - p0`` on X and Y (the paper's
  measured quantities, Table II), ``a = hypot(a_x, a_y)``;
* ``phi`` the angle of the lever P2→P1 at q2 = 0, counter-clockwise from X.
  Increasing q2 (the arm going down) turns the lever clockwise in (X, Y), so
  at joint angle q2 the lever is at ``phi - q2``;
* ``alpha = phi - atan2(a_y, a_x)``, so that the spring length is
  ``s² = a² + L² + 2 a L cos(alpha - q2)`` exactly as eq 4.

The paper writes ``a_x = a cos(alpha)``; with its own Table I and II numbers
that holds only if ``phi = 0``, which Table I contradicts (phi is near 100°).
This module keeps (a_x, a_y) as the measured projections and carries phi
explicitly.  In the robot's joint space the compensator acts on joint 2 with
the generalized force ``-M_c(q2)``: it opposes gravity, which pulls the arm
toward increasing q2.  Its stiffness contribution ``dM_c/dq2 = K_c a L eta``
adds to the joint's own stiffness (eq 8).

The spring of eqs 4-9 is one law of :class:`~bayescal.robot.laws.CompensatorLaw`
(``kind = "spring"`` in the cell's ``[compensator]``, the default); it sits on
any joint (``[compensator] joint`` of the cell) or on none.  Klimchik et al.
note that the approach "can be evidently applied to other compensator types":
:mod:`bayescal.robot.hydro` is the hydro-pneumatic balancer on the same linkage.
The static equilibria of :mod:`bayescal.robot.stiffness` ask a law only its
``torque(q)`` and ``stiffness(q)``; the identification asks its regressor (eq
35 here) and the map from its linear parameters (``K_c``, ``s0·K_c``) back to
its own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from bayescal.robot.laws import LawParameter
from bayescal.units import MM, N_PER_MM

__all__ = ["CompensatorGeometry", "Compensator", "JointCompliance", "MagnitudeAndLength", "MIN_ANGLES", "SPRING_SCALE", "law_on", "alpha", "spring_stiffness", "spring_torque", "stiffness_regressor"]

MIN_ANGLES = 3
"""Distinct angles of the compensated joint that eq 34 needs: one per unknown, K_θ^0, K_c and s0·K_c."""


SPRING_SCALE = np.array([0.05, 0.02])
"""Typical posterior sd of ``log K_c`` and ``s0`` (relative) when the data determine them: the scale of the Gibbs
sampler's mode search and of emcee's initial ball."""


def _out(value: np.ndarray) -> np.ndarray | float:
    return float(value) if np.ndim(value) == 0 else value


def alpha(phi: ArrayLike, a_x: ArrayLike, a_y: ArrayLike) -> np.ndarray:
    """Angle α of eq 4 (rad), ``phi - atan2(a_y, a_x)``, for many geometries at once (arguments broadcast).

    :attr:`CompensatorGeometry.alpha` is the same angle of one geometry.
    """
    return np.asarray(phi, dtype=float) - np.arctan2(a_y, a_x)


def stiffness_regressor(q2: ArrayLike, L: ArrayLike, a_x: ArrayLike, a_y: ArrayLike, phi: ArrayLike) -> np.ndarray:
    """Rows ``C`` of eq 35, with ``K_θ2(q2) = C @ [K_θ2^0, K_c, s0·K_c]`` (eq 8).

    All arguments broadcast against each other, so that one call evaluates
    many angles for many geometries (posterior draws, say).

    Parameters
    ----------
    q2
        Joint angle(s) in rad.
    L, a_x, a_y, phi
        Geometry of :class:`CompensatorGeometry` (m, m, m, rad).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast + (3,)``; the columns are in 1, m², m (so that the
        product is in N·m/rad when the parameters are in N·m/rad, N/m and N).
    """
    q2, L, a_x, a_y, phi = (np.asarray(v, dtype=float) for v in (q2, L, a_x, a_y, phi))
    a = np.hypot(a_x, a_y)
    gamma = alpha(phi, a_x, a_y) - q2
    cos, sin = np.cos(gamma), np.sin(gamma)
    s2 = a**2 + L**2 + 2.0 * a * L * cos
    aL = a * L
    return np.stack(
        np.broadcast_arrays(np.ones_like(gamma), -aL * cos, aL / np.sqrt(s2) * (aL / s2 * sin**2 + cos)),
        axis=-1,
    )


@dataclass(frozen=True)
class CompensatorGeometry:
    """Geometry of the compensator's planar linkage P0-P1-P2.

    Parameters
    ----------
    L
        Lever length ``|P1 P2|`` in m.
    a_x, a_y
        Projections of ``p2 - p0`` on the X and Y axes, in m.
    phi
        Angle of the lever P2→P1 at q2 = 0, counter-clockwise from X, in rad.
    """

    L: float
    a_x: float
    a_y: float
    phi: float

    def __post_init__(self) -> None:
        for name in ("L", "a_x", "a_y", "phi"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)}")
        if self.L <= 0:
            raise ValueError(f"L must be positive, got {self.L}")
        if self.a == 0:
            raise ValueError("p0 and p2 coincide: a_x and a_y are both zero")
        if math.isclose(self.a, self.L, rel_tol=1e-12):
            # s vanishes at gamma = pi and the spring force has no direction there.
            raise ValueError("a equals L: the spring length reaches zero")

    @property
    def vector(self) -> np.ndarray:
        """``[L, a_x, a_y, phi]`` (m, rad)."""
        return np.array([self.L, self.a_x, self.a_y, self.phi])

    @property
    def a(self) -> float:
        """Distance ``|P0 P2|`` in m."""
        return math.hypot(self.a_x, self.a_y)

    @property
    def alpha(self) -> float:
        """Angle of eq 4 in rad: ``phi - atan2(a_y, a_x)``."""
        return self.phi - math.atan2(self.a_y, self.a_x)

    def gamma(self, q2: ArrayLike) -> np.ndarray | float:
        """Angle ``alpha - q2`` between the lever and P0→P2 (rad)."""
        return _out(self.alpha - np.asarray(q2, dtype=float))

    def s(self, q2: ArrayLike) -> np.ndarray | float:
        """Spring length ``|P0 P1|`` in m at joint angle ``q2`` (rad), eq 4."""
        gamma = self.alpha - np.asarray(q2, dtype=float)
        return _out(np.sqrt(self.a**2 + self.L**2 + 2.0 * self.a * self.L * np.cos(gamma)))

    def regressor(self, q2: ArrayLike) -> np.ndarray:
        """Rows ``C`` of eq 35 with ``K_θ2(q2) = C @ [K_θ2^0, K_c, s0·K_c]``: see :func:`stiffness_regressor`."""
        return stiffness_regressor(q2, self.L, self.a_x, self.a_y, self.phi)

    def with_spring(self, K_c: float, s0: float) -> Compensator:
        """This geometry with a spring of stiffness ``K_c`` (N/m) and free length ``s0`` (m)."""
        return Compensator(self.L, self.a_x, self.a_y, self.phi, K_c, s0)


class JointCompliance:
    """What follows of a law's ``stiffness(q)`` for the joint it acts on (eq 8); a mixin of every law."""

    def joint_stiffness(self, q2: ArrayLike, K0: float) -> np.ndarray | float:
        """Equivalent stiffness of joint 2, ``K_θ2 = K0 + dM_c/dq`` in N·m/rad, eq 8.

        Parameters
        ----------
        q2
            Joint angle(s) in rad.
        K0
            Stiffness of joint 2 without its compensator, ``K_θ2^0``, in N·m/rad.
        """
        return _out(K0 + np.asarray(self.stiffness(q2)))

    def equivalent_compliance(self, q2: ArrayLike, own: ArrayLike) -> np.ndarray | float:
        """Compliance of joint 2 with its compensator, ``1 / (1/own + dM_c/dq)`` (eq 8), in rad/(N·m).

        ``own`` is the joint's compliance without the compensator, ``1/K_θ2^0``.
        """
        return _out(1.0 / (1.0 / np.asarray(own, dtype=float) + np.asarray(self.stiffness(q2))))

    def own_compliance(self, q2: ArrayLike, equivalent: ArrayLike) -> np.ndarray | float:
        """The inverse of :meth:`equivalent_compliance`: joint 2's own compliance ``1/K_θ2^0`` (rad/(N·m))
        that, with this compensator at ``q2``, gives the ``equivalent`` compliance."""
        return _out(1.0 / (1.0 / np.asarray(equivalent, dtype=float) - np.asarray(self.stiffness(q2))))


class MagnitudeAndLength:
    """The sampled coordinates of a law whose identified parameters are a positive magnitude and a length that the
    linkage bounds (the spring's ``[K_c, s0]``, the gas cylinder's ``[F0, h0]``), ``z = [log magnitude, length]``: a
    mixin of such laws' eq-34 block."""

    def block_values(self, z: np.ndarray) -> np.ndarray:
        """``(c, 2)`` ``[magnitude, length]`` of ``z = [log magnitude, length]``."""
        return np.column_stack([np.exp(z[:, 0]), z[:, 1]])

    def block_coordinates(self, values: ArrayLike) -> np.ndarray:
        """``(..., 2)`` ``[log magnitude, length]`` of ``(..., 2)`` ``[magnitude, length]`` (``-inf`` or nan outside the support)."""
        values = np.asarray(values, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.stack([np.log(values[..., 0]), values[..., 1]], axis=-1)

    def block_log_jacobian(self, z: np.ndarray) -> np.ndarray:
        """``log magnitude``: the magnitude's flat prior on the positive half-line, in its log."""
        return z[:, 0]

    def block_inside(self, z: np.ndarray, geometry: np.ndarray) -> np.ndarray:
        """``0 < length < a + L``, the longest the linkage P0-P1 can be (the length's flat prior; an unbounded one would
        leave the posterior improper whenever the data do not exclude a zero magnitude, where the length has no effect)."""
        return (z[:, 1] > 0) & (z[:, 1] < np.hypot(geometry[:, 1], geometry[:, 2]) + geometry[:, 0])


@dataclass(frozen=True)
class Compensator(CompensatorGeometry, JointCompliance, MagnitudeAndLength):
    """A spring compensator: the linkage geometry plus the spring (eqs 5-9).

    Parameters
    ----------
    L, a_x, a_y, phi
        Geometry, see :class:`CompensatorGeometry` (m, rad).
    K_c
        Spring stiffness in N/m.
    s0
        Free length of the spring in m (the length at which it exerts no force).
    """

    K_c: float
    s0: float

    kind: ClassVar[str] = "spring"
    PARAMETERS: ClassVar[tuple[LawParameter, ...]] = (
        LawParameter("K_c", "K_c", N_PER_MM, "N/mm", "K_c_N_per_mm", "stiffness of the compensator's spring (eq 7)", "non_negative"),
        LawParameter("s0", "s_0", MM, "mm", "s0_mm", "free length of the compensator's spring (eq 7)", "non_negative"),
    )
    CONSTANTS: ClassVar[tuple[LawParameter, ...]] = ()
    COORDINATES: ClassVar[tuple[str, ...]] = ("log_K_c", "s0")
    LINEAR: ClassVar[tuple[str, ...]] = ("K_c", "s0*K_c")
    REQUIRES: ClassVar[dict[str, str]] = {"s0": "K_c"}
    THROUGH: ClassVar[dict[str, str]] = {"s0": "the product s0·K_c"}
    EXACT_REGRESSOR: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.K_c) and self.K_c >= 0):
            raise ValueError(f"K_c must be finite and non-negative, got {self.K_c}")
        if not (math.isfinite(self.s0) and self.s0 >= 0):
            raise ValueError(f"s0 must be finite and non-negative, got {self.s0}")

    @property
    def values(self) -> tuple[float, float]:
        """``(K_c, s0)`` in N/m and m."""
        return (self.K_c, self.s0)

    def at(self, geometry: ArrayLike, values: ArrayLike) -> Compensator:
        """A spring ``values`` ``(K_c, s0)`` (N/m, m) on ``geometry`` ``[L, a_x, a_y, phi]`` (m, rad)."""
        return Compensator(*(float(v) for v in geometry), *(float(v) for v in values))

    @property
    def geometry(self) -> CompensatorGeometry:
        """The linkage geometry alone."""
        return CompensatorGeometry(self.L, self.a_x, self.a_y, self.phi)

    def spring_force(self, q2: ArrayLike) -> np.ndarray | float:
        """Spring force ``F_s = K_c (s - s0)`` in N, eq 5 (positive when stretched)."""
        return _out(self.K_c * (np.asarray(self.s(q2)) - self.s0))

    def torque(self, q2: ArrayLike) -> np.ndarray | float:
        """Compensator torque ``M_c`` about joint 2 in N·m, eq 7.

        The generalized force on q2 in the robot's joint space is ``-M_c``.
        """
        return _out(spring_torque(self, self.K_c, self.s0, q2))

    def eta(self, q2: ArrayLike) -> np.ndarray | float:
        """Dimensionless coefficient ``eta(q2)`` of eq 9."""
        return _out(_eta(self, self.s0, q2))

    def stiffness(self, q2: ArrayLike) -> np.ndarray | float:
        """The compensator's contribution ``K_c a L eta = dM_c/dq2`` to joint 2, in N·m/rad."""
        return _out(spring_stiffness(self, self.K_c, self.s0, q2))

    def linear(self, values: ArrayLike) -> np.ndarray:
        """``[K_c, s0·K_c]`` (N/m, N) of ``(..., 2)`` values ``[K_c, s0]``: the unknowns of eq 35."""
        values = np.asarray(values, dtype=float)
        return np.stack([values[..., 0], values[..., 1] * values[..., 0]], axis=-1)

    def from_linear(self, w: ArrayLike) -> np.ndarray:
        """``[K_c, s0]`` of eq 35's ``w = [K_c, s0·K_c]`` (``s0`` nan when ``K_c`` is 0)."""
        return np.array([w[0], w[1] / w[0] if w[0] != 0 else np.nan])

    def linear_jacobian(self, w: ArrayLike) -> np.ndarray:
        """``(2, 2)`` derivatives of ``[K_c, s0] = [w0, w1 / w0]`` with respect to ``w``."""
        return np.array([[1.0, 0.0], [-w[1] / w[0] ** 2, 1.0 / w[0]]])

    def torque_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``M_c`` (N·m) of springs ``values`` ``(N, 2)`` ``[K_c, s0]`` on this linkage at angles ``q`` ``(N,)``."""
        return spring_torque(self, values[:, 0], values[:, 1], q)

    def stiffness_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``dM_c/dq`` (N·m/rad) of springs ``values`` ``(N, 2)`` on this linkage at angles ``q`` ``(N,)``."""
        return spring_stiffness(self, values[:, 0], values[:, 1], q)

    def compliance_gradient(self, q: ArrayLike, effective: ArrayLike) -> np.ndarray:
        """``(..., 2)`` derivatives in ``K_c`` and ``s0`` of the joint's equivalent compliance ``effective``
        (rad/(N·m)) at angle(s) ``q``: ``-effective²`` times those of ``K_c a L eta``, which with eq 35's
        ``C1·K_c + C2·s0·K_c`` are ``C1 + s0·C2`` and ``K_c·C2``."""
        regressor = self.regressor(q)
        c1, c2 = regressor[..., 1], regressor[..., 2]
        return np.stack([-effective**2 * (c1 + self.s0 * c2), -effective**2 * self.K_c * c2], axis=-1)

    def prior_sd(self) -> dict[str, float | None]:
        """``{name: prior sd}`` in edge units, None for K_c's flat prior on the half-line; s0's is flat on
        ``(0, a + L)`` (:meth:`block_inside`): its sd is the width over sqrt(12)."""
        return {"K_c": None, "s0": (math.hypot(self.a_x, self.a_y) + self.L) / math.sqrt(12.0) / MM}

    def joint_stiffness_of(self, q: ArrayLike, geometry: np.ndarray, spring: np.ndarray) -> np.ndarray:
        """``(S, m)`` eq 8's ``K_θ^0 + K_c a L eta`` at ``(m,)`` angles for ``(S, 4)`` geometries and ``(S, 3)`` springs."""
        C = stiffness_regressor(np.asarray(q, dtype=float)[None, :], *(geometry[:, i, None] for i in range(4)))
        w = np.column_stack([spring[:, 0], spring[:, 1], spring[:, 2] * spring[:, 1]])
        return np.einsum("smk,sk->sm", C, w)

    def block_rows(self, q: np.ndarray, geometry: np.ndarray | None) -> np.ndarray:
        """``(c|1, m + 1, 3)`` eq-35 rows at ``q`` for ``(c, 4)`` geometries (this spring's own when None)."""
        if geometry is None:
            return stiffness_regressor(q, self.L, self.a_x, self.a_y, self.phi)[None]
        return stiffness_regressor(q[None, :], *(geometry[:, i, None] for i in range(4)))

    def block_change(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c, m)`` ``K_c a L (eta(q) - eta(q_ref))`` at ``z = [log K_c, s0]``."""
        change = rows[..., :-1, 1:] - rows[..., -1:, 1:]
        return np.exp(z[:, 0])[:, None] * (change[..., 0] + change[..., 1] * z[:, 1:2])

    def block_reference(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c,)`` ``K_c a L eta(q_ref)`` at ``z = [log K_c, s0]``."""
        reference = rows[..., -1, :]
        return np.exp(z[:, 0]) * (reference[..., 1] + reference[..., 2] * z[:, 1])

    def block_scale(self, values: ArrayLike) -> np.ndarray:
        """:data:`SPRING_SCALE` of ``log K_c`` and of ``s0`` relative to ``values[1]``."""
        return SPRING_SCALE * np.abs([1.0, values[1]])

    def static_point(self, values: ArrayLike) -> np.ndarray:
        """``(..., 2)`` ``[K_c, K_c s0]`` (N/m, N): the static torque of eq 7 is linear in them."""
        values = np.asarray(values, dtype=float)
        return np.stack([values[..., 0], values[..., 0] * values[..., 1]], axis=-1)

    def from_static(self, u: ArrayLike) -> tuple[float, float]:
        """``(K_c, s0)`` of ``u = [K_c, K_c s0]``."""
        return float(u[0]), float(u[1] / u[0])

    def static_steps(self, values: ArrayLike, steps: ArrayLike) -> list[tuple[float, tuple[float, float]]]:
        """``K_c`` moved by ``steps[0]`` of itself at fixed ``K_c s0``, then ``K_c s0`` by ``steps[1]`` of itself."""
        Kc, s0 = values
        dKc, dP = steps[0] * Kc, steps[1] * Kc * s0
        return [(dKc, (Kc + dKc, Kc * s0 / (Kc + dKc))), (dP, (Kc, s0 + dP / Kc))]


def spring_torque(geometry: CompensatorGeometry, K_c: ArrayLike, s0: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """:meth:`Compensator.torque` (N·m, eq 7) of springs ``K_c`` (N/m) and ``s0`` (m) on one ``geometry``, the
    arguments broadcast against each other: many springs in one call (the batched equilibria's variants)."""
    gamma = geometry.alpha - np.asarray(q2, dtype=float)
    s = np.asarray(geometry.s(q2))
    return K_c * (1.0 - s0 / s) * geometry.a * geometry.L * np.sin(gamma)


def _eta(geometry: CompensatorGeometry, s0: ArrayLike, q2: ArrayLike) -> np.ndarray:
    gamma = geometry.alpha - np.asarray(q2, dtype=float)
    s = np.asarray(geometry.s(q2))
    aL = geometry.a * geometry.L
    return s0 / s * (aL / s**2 * np.sin(gamma) ** 2 + np.cos(gamma)) - np.cos(gamma)


def spring_stiffness(geometry: CompensatorGeometry, K_c: ArrayLike, s0: ArrayLike, q2: ArrayLike) -> np.ndarray:
    """:meth:`Compensator.stiffness` (N·m/rad, ``K_c a L eta``) of springs ``K_c`` and ``s0`` on one ``geometry``, arguments broadcast."""
    return K_c * geometry.a * geometry.L * np.asarray(_eta(geometry, s0, q2))


def law_on(law, geometry: ArrayLike, values: ArrayLike | None = None):
    """The law ``law`` on ``geometry`` ``[L, a_x, a_y, phi]`` (m, rad) with ``values`` (default: its own).

    ``law`` None stands for the spring of eqs 4-9 (its ``values`` zero unless given): what a caller that names no
    law (a model built by hand rather than from a cell) meant before there was more than one.
    """
    if law is None:
        return Compensator(*(float(g) for g in geometry), *((0.0, 0.0) if values is None else (float(v) for v in values)))
    return law.at(geometry, law.values if values is None else values)
