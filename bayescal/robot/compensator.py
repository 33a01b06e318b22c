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

The spring of eqs 4-9 is the one kind of compensator; it sits on any joint
(``[compensator] joint`` of the cell) or on none.  Klimchik et al. note that
the approach "can be evidently applied to other compensator types" (a gas or
hydraulic balancer).  Another kind is one class beside :class:`Compensator`
with its two laws in SI, both vectorised over the joint angle:
``torque(q)``, the generalized force ``M_c(q)`` it takes off the joint
(N·m), and ``stiffness(q) = dM_c/dq``, what it adds to the joint's stiffness
(N·m/rad), with ``equivalent_compliance`` and ``own_compliance`` following
from it as here.  The static equilibria of :mod:`bayescal.robot.stiffness`
(hence the twin, the exact model, the test pose and ``bayescal compensate``)
ask only these.  The identification then takes the compensated joint's
compliance per angle (eq 33) for any kind; separating the kind's own
parameters from that joint's stiffness, as eq 34 does for ``K_c`` and ``s0``,
needs the kind's regressor in place of :func:`stiffness_regressor` in
:mod:`bayescal.inference.likelihood` and :mod:`bayescal.inference.closedform`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["CompensatorGeometry", "Compensator", "MIN_ANGLES", "alpha", "spring_stiffness", "spring_torque", "stiffness_regressor"]

MIN_ANGLES = 3
"""Distinct angles of the compensated joint that eq 34 needs: one per unknown, K_θ^0, K_c and s0·K_c."""


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


@dataclass(frozen=True)
class Compensator(CompensatorGeometry):
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

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.K_c) and self.K_c >= 0):
            raise ValueError(f"K_c must be finite and non-negative, got {self.K_c}")
        if not (math.isfinite(self.s0) and self.s0 >= 0):
            raise ValueError(f"s0 must be finite and non-negative, got {self.s0}")

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

    def joint_stiffness(self, q2: ArrayLike, K0: float) -> np.ndarray | float:
        """Equivalent stiffness of joint 2, ``K_θ2 = K0 + K_c a L eta`` in N·m/rad, eq 8.

        Parameters
        ----------
        q2
            Joint angle(s) in rad.
        K0
            Stiffness of joint 2 without its compensator, ``K_θ2^0``, in N·m/rad.
        """
        return _out(K0 + np.asarray(self.stiffness(q2)))

    def equivalent_compliance(self, q2: ArrayLike, own: ArrayLike) -> np.ndarray | float:
        """Compliance of joint 2 with its compensator, ``1 / (1/own + K_c a L eta)`` (eq 8), in rad/(N·m).

        ``own`` is the joint's compliance without the compensator, ``1/K_θ2^0``.
        """
        return _out(1.0 / (1.0 / np.asarray(own, dtype=float) + np.asarray(self.stiffness(q2))))

    def own_compliance(self, q2: ArrayLike, equivalent: ArrayLike) -> np.ndarray | float:
        """The inverse of :meth:`equivalent_compliance`: joint 2's own compliance ``1/K_θ2^0`` (rad/(N·m))
        that, with this compensator at ``q2``, gives the ``equivalent`` compliance."""
        return _out(1.0 / (1.0 / np.asarray(equivalent, dtype=float) - np.asarray(self.stiffness(q2))))


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
