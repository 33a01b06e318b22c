"""What a gravity compensator's law is to the rest of the package: the :class:`CompensatorLaw` protocol.

A compensator acts on one revolute joint through the planar linkage of eq 4
(lever ``L``, pivot offsets ``a_x``, ``a_y``, lever angle ``phi``; see
:mod:`bayescal.robot.compensator`).  Its *law* says which force the device
exerts along the line P0-P1 of length ``s(q)``, and so its torque and the
stiffness it adds to the joint (eq 8).  The spring of eqs 4-9
(:class:`~bayescal.robot.compensator.Compensator`) is one law; the
hydro-pneumatic balancer (:class:`~bayescal.robot.hydro.HydroCompensator`) is
another.  :data:`bayescal.robot.kinds.LAWS` names them by the ``kind`` key of the
cell's ``[compensator]`` table.

Every law is identified the same way (eqs 33-35): the compensated joint's
stiffness at each campaign angle, ``K(q) = K_θ^0 + dM_c/dq``, is written as
``C(q) @ [K_θ^0, *w]`` with the law's regressor rows ``C`` and its *linear
parameters* ``w`` (``K_c`` and ``s0·K_c`` for the spring); the law maps ``w``
back to its identified parameters and gives that map's Jacobian for the
intervals.  A law whose regressor depends on its own parameters (not the
spring's) is regressed again at the parameters it found until they settle
(:func:`bayescal.inference.closedform.closed_form`).

Adding a law: one module in ``bayescal/robot/`` with a frozen dataclass deriving
from :class:`~bayescal.robot.compensator.CompensatorGeometry` that implements
this protocol, its name in :data:`bayescal.robot.kinds.LAWS`, its cell keys in
its :attr:`CompensatorLaw.PARAMETERS` and :attr:`CompensatorLaw.CONSTANTS`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["CompensatorLaw", "LawParameter"]


@dataclass(frozen=True)
class LawParameter:
    """One number of a compensator law: identified (``PARAMETERS``) or given by the cell (``CONSTANTS``).

    Attributes
    ----------
    name : str
        Its field on the law's class and its key in every table and JSON (``K_c``).
    symbol : str
        How it is written in reports, plain text (``K_c``, ``s_0``).
    si_factor : float
        The SI value of one edge unit.
    unit : str
        The unit at the edges (cell file, JSON, reports).
    key : str
        Its key in the cell's ``[compensator]`` table, unit in the name (``K_c_N_per_mm``).
    description : str
        What it is, in a few words.
    bound : str
        ``"positive"``, ``"non_negative"`` or ``""``: what the cell reader requires of it.
    """

    name: str
    symbol: str
    si_factor: float
    unit: str
    key: str
    description: str
    bound: str = ""


class CompensatorLaw(Protocol):
    """A compensator of one kind on its geometry, with its parameters' values (SI throughout).

    The methods taking arrays broadcast them (many angles, many posterior draws at once).
    """

    kind: ClassVar[str]
    """The cell's ``[compensator] kind`` of this law."""
    PARAMETERS: ClassVar[tuple[LawParameter, ...]]
    """The identified parameters, in the order of :attr:`values`."""
    CONSTANTS: ClassVar[tuple[LawParameter, ...]]
    """What the cell gives and the identification keeps fixed, beside the geometry."""
    COORDINATES: ClassVar[tuple[str, ...]]
    """Names of the sampler's coordinates of the law (:meth:`block_coordinates`)."""
    LINEAR: ClassVar[tuple[str, ...]]
    """Names of the linear parameters (:meth:`linear`), as the reasons of a rank-deficient regression say them."""
    REQUIRES: ClassVar[dict[str, str]]
    """``{name: other}``: a parameter that the data determine only through another (s0 only through K_c)."""
    THROUGH: ClassVar[dict[str, str]]
    """``{name: words}``: how each of :attr:`REQUIRES` enters the model (``the product s0·K_c``)."""
    EXACT_REGRESSOR: ClassVar[bool]
    """Whether :meth:`regressor` is the same at any parameters (the spring's): one regression suffices."""

    @property
    def vector(self) -> np.ndarray:
        """The geometry ``[L, a_x, a_y, phi]`` (m, rad)."""

    @property
    def values(self) -> tuple[float, ...]:
        """The identified parameters' values in SI, in the order of :attr:`PARAMETERS`."""

    def at(self, geometry: ArrayLike, values: ArrayLike) -> CompensatorLaw:
        """This law (its constants) on ``geometry`` ``[L, a_x, a_y, phi]`` (m, rad) with parameters ``values`` (SI)."""

    def torque(self, q: ArrayLike) -> np.ndarray | float:
        """Torque ``M_c`` it takes off the joint at angle(s) ``q`` (rad), N·m."""

    def stiffness(self, q: ArrayLike) -> np.ndarray | float:
        """``dM_c/dq`` (N·m/rad): what it adds to the joint's stiffness at ``q`` (rad)."""

    def torque_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``(N,)`` torques (N·m) of ``(N, p)`` parameter values on this linkage at ``(N,)`` angles (rad)."""

    def stiffness_of(self, values: np.ndarray, q: ArrayLike) -> np.ndarray:
        """``(N,)`` stiffnesses ``dM_c/dq`` (N·m/rad) of ``(N, p)`` parameter values at ``(N,)`` angles."""

    def regressor(self, q: ArrayLike) -> np.ndarray:
        """``(..., 1 + p)`` rows ``C(q)`` with the joint's stiffness ``C @ [K_θ^0, *linear(values)]`` (N·m/rad)."""

    def linear(self, values: ArrayLike) -> np.ndarray:
        """``(..., p)`` the linear parameters of ``(..., p)`` identified values (SI)."""

    def from_linear(self, w: ArrayLike) -> np.ndarray:
        """``(p,)`` identified values (SI) of the linear parameters ``w``: the inverse of :meth:`linear`."""

    def linear_jacobian(self, w: ArrayLike) -> np.ndarray:
        """``(p, p)`` derivatives of :meth:`from_linear` with respect to ``w``."""

    def compliance_gradient(self, q: ArrayLike, effective: ArrayLike) -> np.ndarray:
        """``(..., p)`` derivatives in the identified parameters of the joint's equivalent compliance ``effective``
        (rad/(N·m), eq 8) at angle(s) ``q``: ``-effective²`` times those of :meth:`stiffness`."""

    def prior_sd(self) -> dict[str, float | None]:
        """``{name: sd of its prior}`` in edge units; None for a flat prior on a half-line (no sd)."""

    def joint_stiffness_of(self, q: ArrayLike, geometry: np.ndarray, spring: np.ndarray) -> np.ndarray:
        """``(S, m)`` the joint's stiffness (N·m/rad) at angles ``q`` ``(m,)`` for ``S`` geometries ``(S, 4)``
        and ``spring`` draws ``(S, 1 + p)`` ``[K_θ^0, *values]``."""

    def block_rows(self, q: np.ndarray, geometry: np.ndarray | None) -> np.ndarray:
        """What the sampler's block needs of the geometry at angles ``q`` (``(m + 1,)``, the reference last):
        ``(c|1, m + 1, r)`` for ``(c, 4)`` geometries, or the law's own geometry when None."""

    def block_change(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c, m)`` the law's stiffness at the campaign's angles minus at the reference, at coordinates ``z`` ``(c, k)``."""

    def block_reference(self, z: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``(c,)`` the law's stiffness at the reference angle."""

    def block_values(self, z: np.ndarray) -> np.ndarray:
        """``(c, p)`` identified values of the sampler's coordinates ``z``."""

    def block_coordinates(self, values: ArrayLike) -> np.ndarray:
        """``(..., k)`` the sampler's coordinates of ``(..., p)`` identified ``values``: the inverse of :meth:`block_values`."""

    def block_log_jacobian(self, z: np.ndarray) -> np.ndarray:
        """``(c,)`` log of the Jacobian that carries the flat priors of :attr:`PARAMETERS` to the coordinates."""

    def block_inside(self, z: np.ndarray, geometry: np.ndarray) -> np.ndarray:
        """``(c,)`` whether ``z`` lies in the prior's support, for ``(c|1, 4)`` geometries."""

    def block_scale(self, values: ArrayLike) -> np.ndarray:
        """``(k,)`` typical posterior sd of the coordinates when the data determine them (the sampler's start)."""

    def static_point(self, values: ArrayLike) -> np.ndarray:
        """``(..., p)`` coordinates in which the law's torque is (nearly) linear, of ``(..., p)`` values."""

    def from_static(self, u: ArrayLike) -> tuple[float, ...]:
        """Identified values of the static coordinates ``u``: the inverse of :meth:`static_point`."""

    def static_steps(self, values: ArrayLike, steps: ArrayLike) -> list[tuple[float, tuple[float, ...]]]:
        """For each static coordinate, its finite-difference step and the values ``steps`` (relative) away along it."""
