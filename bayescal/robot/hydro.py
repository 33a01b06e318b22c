"""A hydro-pneumatic gravity compensator: gas pressure on a piston along the linkage of eq 4.

Heavy arms (KUKA's, ABB's) balance their second axis with a cylinder whose
piston compresses a gas charge as the arm leaves the vertical.  It sits on the
same planar linkage as the spring of eqs 4-9 (lever ``L``, pivot offsets
``a_x``, ``a_y``, lever angle ``phi``; :mod:`bayescal.robot.compensator`), so
that the line P0-P1 has the length ``s(q)`` of eq 4 and ``ds/dq = a L
sin(alpha - q) / s``.  The gas, of pre-charge pressure ``p0`` on a piston of area
``A`` with a column ``h0`` long at the reference length ``s_ref``, follows the
polytropic law ``p V^n = const``, so that the cylinder pulls P1 towards P0 with

    F(s) = p0 A (h0 / (h0 - (s - s_ref)))^n

(a tension like the spring's ``K_c (s - s0)``: positive as the cylinder
extends and compresses the gas).  The torque it takes off the joint is
``M_c = F(s) ds/dq`` and the stiffness it adds ``dM_c/dq = F'(s) (ds/dq)² +
F(s) d²s/dq²`` (eq 8 with this law).

Which parameters are identified, and why.  ``p0`` and ``A`` enter only as their
product, the force ``F0 = p0 A`` at the reference length; ``F0`` and the gas
column ``h0`` are identified, the exponent ``n`` (between 1, isothermal, and
1.4, adiabatic nitrogen) and ``s_ref`` are the cell's, as the geometry is.  With
``k0 = n F0 / h0``, the gas's stiffness at ``s_ref``, the force is ``F0 (1 -
k0 (s - s_ref) / (n F0))^-n``: homogeneous of degree 1 in ``(F0, k0)``, and so
is the joint stiffness it adds.  By Euler's theorem that stiffness equals its
gradient in ``(F0, k0)`` times ``(F0, k0)``: eq 34's regression on these two
columns is exact at the values the columns are taken at, and only their ratio
``h0`` (the curvature of the gas law over the stroke) is nonlinear.  This is as
close to linear as the physics allows: the spring's ``K_c``, ``s0·K_c`` are the
limit ``h0 → ∞`` with ``n F0 / h0`` held; the closed form regresses again at the
``h0`` it found until it settles (:func:`bayescal.inference.closedform.regress`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

from bayescal.robot.compensator import CompensatorGeometry, JointCompliance, MagnitudeAndLength, alpha
from bayescal.robot.laws import LawParameter
from bayescal.units import MM

__all__ = ["HydroCompensator", "KN", "HYDRO_SCALE", "stroke_terms"]

KN = 1e3
"""One kN in N: the unit of the hydro-pneumatic compensator's force at the edges."""
HYDRO_SCALE = np.array([0.05, 0.02])
"""Typical posterior sd of ``log F0`` and ``h0`` (relative) when the data determine them: the scale of the Gibbs
sampler's mode search and of emcee's initial ball (the spring's, :data:`~bayescal.robot.compensator.SPRING_SCALE`)."""


def _out(value: np.ndarray) -> np.ndarray | float:
    return float(value) if np.ndim(value) == 0 else value


def stroke_terms(q: ArrayLike, L: ArrayLike, a_x: ArrayLike, a_y: ArrayLike, phi: ArrayLike, s_ref: float) -> np.ndarray:
    """``(..., 3)`` the linkage's ``[s - s_ref (m), ds/dq (m/rad), d²s/dq² (m/rad²)]`` at angle(s) ``q`` (rad).

    All arguments but ``s_ref`` broadcast against each other (many angles for many geometries).
    """
    q, L, a_x, a_y, phi = (np.asarray(v, dtype=float) for v in (q, L, a_x, a_y, phi))
    aL = np.hypot(a_x, a_y) * L
    gamma = alpha(phi, a_x, a_y) - q
    s = np.sqrt(np.hypot(a_x, a_y) ** 2 + L**2 + 2.0 * aL * np.cos(gamma))
    arm = aL * np.sin(gamma) / s
    return np.stack(np.broadcast_arrays(s - s_ref, arm, -aL * np.cos(gamma) / s - arm**2 / s), axis=-1)


def _force_terms(rows: np.ndarray, F0: ArrayLike, h0: ArrayLike, n: float) -> tuple[np.ndarray, np.ndarray]:
    """``F(s)`` (N) and ``F'(s)`` (N/m) at ``rows`` of :func:`stroke_terms`; nan where the gas column is used up."""
    ratio = 1.0 - rows[..., 0] / h0
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(ratio > 0, ratio, np.nan)
        force = F0 * ratio**-n
    return force, force * n / (h0 * ratio)


def _stiffness(rows: np.ndarray, F0: ArrayLike, h0: ArrayLike, n: float) -> np.ndarray:
    """``dM_c/dq = F' (ds/dq)² + F d²s/dq²`` (N·m/rad) at ``rows`` of :func:`stroke_terms`."""
    force, slope = _force_terms(rows, F0, h0, n)
    return slope * rows[..., 1] ** 2 + force * rows[..., 2]


def _stiffness_h0(rows: np.ndarray, F0: ArrayLike, h0: ArrayLike, n: float) -> np.ndarray:
    """``∂(dM_c/dq)/∂h0`` (N·m/(rad·m)) at fixed ``F0``: ``∂F/∂h0 = -n u F / (h0² r)`` with ``r = 1 - u/h0``."""
    force, slope = _force_terms(rows, F0, h0, n)
    u = rows[..., 0]
    ratio = 1.0 - u / h0
    d_force = -slope * u / h0
    # F' = n F / (h0 r): its derivative in h0 adds -F'/h0 and, through r, -(n + 1) u F' / (h0² r).
    d_slope = -slope / h0 - (n + 1.0) * u * slope / (h0**2 * ratio)
    return d_slope * rows[..., 1] ** 2 + d_force * rows[..., 2]


@dataclass(frozen=True)
class HydroCompensator(CompensatorGeometry, JointCompliance, MagnitudeAndLength):
    """A hydro-pneumatic compensator on the linkage of eq 4 (SI: m, rad, N).

    Parameters
    ----------
    L, a_x, a_y, phi
        Geometry, see :class:`~bayescal.robot.compensator.CompensatorGeometry` (m, rad).
    F0
        Force ``p0 A`` along P0-P1 at the reference length, N (identified).
    h0
        Length of the gas column at the reference length, m (identified).
    n
        Polytropic exponent of the gas, 1 (isothermal) to 1.4 (adiabatic nitrogen).
    s_ref
        Length ``|P0 P1|`` (m) at which the force is ``F0`` and the gas column ``h0``.
    """

    F0: float
    h0: float
    n: float
    s_ref: float

    kind: ClassVar[str] = "hydro"
    PARAMETERS: ClassVar[tuple[LawParameter, ...]] = (
        LawParameter("F0", "F_0", KN, "kN", "F0_kN", "force of the hydro-pneumatic cylinder at its reference length", "non_negative"),
        LawParameter("h0", "h_0", MM, "mm", "h0_mm", "gas column of the hydro-pneumatic cylinder at its reference length", "positive"),
    )
    CONSTANTS: ClassVar[tuple[LawParameter, ...]] = (
        LawParameter("n", "n", 1.0, "1", "n_polytropic", "polytropic exponent of the gas", "positive"),
        LawParameter("s_ref", "s_ref", MM, "mm", "s_ref_mm", "length P0-P1 at which the force is F0", "positive"),
    )
    COORDINATES: ClassVar[tuple[str, ...]] = ("log_F0", "h0")
    LINEAR: ClassVar[tuple[str, ...]] = ("F0", "n*F0/h0")
    REQUIRES: ClassVar[dict[str, str]] = {"h0": "F0"}
    THROUGH: ClassVar[dict[str, str]] = {"h0": "the gas's stiffness n·F0/h0 and its curvature over the stroke"}
    EXACT_REGRESSOR: ClassVar[bool] = False

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (math.isfinite(self.F0) and self.F0 >= 0):
            raise ValueError(f"F0 must be finite and non-negative, got {self.F0}")
        for name in ("h0", "n", "s_ref"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"{name} must be finite and positive, got {getattr(self, name)}")

    @property
    def values(self) -> tuple[float, float]:
        """``(F0, h0)`` in N and m."""
        return (self.F0, self.h0)

    def at(self, geometry: ArrayLike, values: ArrayLike) -> HydroCompensator:
        """This cylinder's gas (``n``, ``s_ref``) with ``values`` ``(F0, h0)`` on ``geometry`` ``[L, a_x, a_y, phi]``."""
        return HydroCompensator(*(float(v) for v in geometry), *(float(v) for v in values), self.n, self.s_ref)

    def _rows(self, q: ArrayLike) -> np.ndarray:
        return stroke_terms(q, self.L, self.a_x, self.a_y, self.phi, self.s_ref)

    def force(self, q: ArrayLike) -> np.ndarray | float:
        """The cylinder's pull ``F(s)`` (N) at joint angle(s) ``q`` (rad); nan where the gas column is used up."""
        return _out(_force_terms(self._rows(q), self.F0, self.h0, self.n)[0])

    def torque(self, q: ArrayLike) -> np.ndarray | float:
        """``M_c = F(s) ds/dq`` (N·m) at angle(s) ``q`` (rad)."""
        rows = self._rows(q)
        return _out(_force_terms(rows, self.F0, self.h0, self.n)[0] * rows[..., 1])

    def stiffness(self, q: ArrayLike) -> np.ndarray | float:
        """``dM_c/dq`` (N·m/rad) at angle(s) ``q`` (rad)."""
        return _out(_stiffness(self._rows(q), self.F0, self.h0, self.n))

    def torque_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``M_c`` (N·m) of ``(N, 2)`` values ``[F0, h0]`` on this linkage at ``(N,)`` angles."""
        rows = self._rows(q)
        return _force_terms(rows, values[:, 0], values[:, 1], self.n)[0] * rows[..., 1]

    def stiffness_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``dM_c/dq`` (N·m/rad) of ``(N, 2)`` values ``[F0, h0]`` at ``(N,)`` angles."""
        return _stiffness(self._rows(q), values[:, 0], values[:, 1], self.n)

    def regressor(self, q: ArrayLike) -> np.ndarray:
        """``(..., 3)`` rows with the joint's stiffness ``C @ [K_θ^0, F0, k0]``, ``k0 = n F0 / h0``: the gradient in
        ``(F0, k0)`` at this ``h0``, ``[1, g + h0 g', -h0² g' / n]`` with ``F0 g(h0)`` the law's stiffness."""
        rows = self._rows(q)
        g = _stiffness(rows, 1.0, self.h0, self.n)
        dg = _stiffness_h0(rows, 1.0, self.h0, self.n)
        return np.stack(np.broadcast_arrays(np.ones_like(g), g + self.h0 * dg, -self.h0**2 * dg / self.n), axis=-1)

    def linear(self, values: ArrayLike) -> np.ndarray:
        """``[F0, n F0 / h0]`` (N, N/m) of ``(..., 2)`` values ``[F0, h0]``."""
        values = np.asarray(values, dtype=float)
        return np.stack([values[..., 0], self.n * values[..., 0] / values[..., 1]], axis=-1)

    def from_linear(self, w: ArrayLike) -> np.ndarray:
        """``[F0, h0] = [w0, n w0 / w1]`` (``h0`` nan when ``w1`` is 0)."""
        return np.array([w[0], self.n * w[0] / w[1] if w[1] != 0 else np.nan])

    def linear_jacobian(self, w: ArrayLike) -> np.ndarray:
        """``(2, 2)`` derivatives of ``[w0, n w0 / w1]`` with respect to ``w``."""
        return np.array([[1.0, 0.0], [self.n / w[1], -self.n * w[0] / w[1] ** 2]])

    def joint_stiffness_of(self, q: ArrayLike, geometry: np.ndarray, spring: np.ndarray) -> np.ndarray:
        """``(S, m)`` ``K_θ^0 + dM_c/dq`` at ``(m,)`` angles for ``(S, 4)`` geometries and ``(S, 3)`` ``[K_θ^0, F0, h0]``."""
        rows = self.block_rows(np.asarray(q, dtype=float), geometry)
        return spring[:, :1] + _stiffness(rows, spring[:, 1:2], spring[:, 2:3], self.n)

    def block_rows(self, q: np.ndarray, geometry: np.ndarray | None) -> np.ndarray:
        """``(c|1, m + 1, 3)`` :func:`stroke_terms` at ``q`` for ``(c, 4)`` geometries (this cylinder's own when None)."""
        if geometry is None:
            return self._rows(q)[None]
        return stroke_terms(q[None, :], *(geometry[:, i, None] for i in range(4)), self.s_ref)

    def _block_stiffness(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        return _stiffness(rows, np.exp(z[:, :1]), z[:, 1:2], self.n)

    def block_change(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c, m)`` ``dM_c/dq`` at the campaign's angles minus at the reference, at ``z = [log F0, h0]``."""
        stiffness = self._block_stiffness(z, rows)
        return stiffness[:, :-1] - stiffness[:, -1:]

    def block_reference(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c,)`` ``dM_c/dq`` at the reference angle."""
        return self._block_stiffness(z, rows)[:, -1]

    def block_scale(self, values: ArrayLike) -> np.ndarray:
        """:data:`HYDRO_SCALE` of ``log F0`` and of ``h0`` relative to ``values[1]``."""
        return HYDRO_SCALE * np.abs([1.0, values[1]])

    def static_point(self, values: ArrayLike) -> np.ndarray:
        """``(..., 2)`` ``[F0, n F0 / h0]`` (N, N/m): the torque is homogeneous of degree 1 in them."""
        return self.linear(values)

    def from_static(self, u: ArrayLike) -> tuple[float, float]:
        """``(F0, h0)`` of ``u = [F0, n F0 / h0]``."""
        return float(u[0]), float(self.n * u[0] / u[1])

    def static_steps(self, values: ArrayLike, steps: ArrayLike) -> list[tuple[float, tuple[float, float]]]:
        """``F0`` moved by ``steps[0]`` of itself at fixed ``k0 = n F0 / h0``, then ``k0`` by ``steps[1]`` of itself."""
        F0, h0 = values
        dF, dk = steps[0] * F0, steps[1] * self.n * F0 / h0
        return [(dF, (F0 + dF, h0 * (F0 + dF) / F0)), (dk, (F0, self.n * F0 / (self.n * F0 / h0 + dk)))]

    def compliance_gradient(self, q: ArrayLike, effective: ArrayLike) -> np.ndarray:
        """``(..., 2)`` derivatives of the equivalent compliance ``effective`` (rad/(N·m)) in ``F0`` and ``h0``."""
        rows = self._rows(q)
        gradient = np.stack([_stiffness(rows, 1.0, self.h0, self.n), _stiffness_h0(rows, self.F0, self.h0, self.n)], axis=-1)
        return -np.asarray(effective)[..., None] ** 2 * gradient

    def prior_sd(self) -> dict[str, float | None]:
        """``{F0: None, h0: sd}`` in edge units: F0's flat prior on the half-line has none; h0's is flat on
        ``(0, a + L)`` (:meth:`block_inside`), its sd the width over sqrt(12)."""
        return {"F0": None, "h0": (math.hypot(self.a_x, self.a_y) + self.L) / math.sqrt(12.0) / MM}
