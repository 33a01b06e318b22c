"""The loaded static equilibrium of a virtual-joint arm, written apart from ``bayescal.robot.stiffness``.

Each joint is a drive held at the commanded angle ``q`` in series with a spring
(Klimchik et al., eq 1, in joint space).  The links sit at ``q + θ + b``, ``b``
the lost motion of the gears (zero unless an effect sets it), and the springs
carry the generalized force of every load at that pose::

    θ = D(τ),   τ = -g(q_link) - M_c(q_link[c])·e_c + J_p(q_link)ᵀ f + J_ω(q_link)ᵀ m

``g`` is Pinocchio's gravity torque of the (mass-scaled) links, ``M_c`` the
compensator's moment of eqs 4-7 on joint ``c`` (it acts between the links, so in
parallel with the joint's spring, on the link angle), ``f`` the load's force at a
material point of the tool and ``m`` a dead couple.  ``D`` is the joints'
deflection law.  The equation is solved with MINPACK's hybrid method
(``scipy.optimize.root``), which needs no derivative of ``D``, so that laws with
knees or lost motion need no special treatment.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import root

from bayescal.robot.kinematics import Robot, scaled_links

__all__ = ["SpringLinkage", "Load", "Statics", "scaled_robot", "SolverError"]

_RESIDUAL_TOLERANCE = 1e-12
"""Largest |θ - D(τ)| (rad) accepted as an equilibrium: a micrometre at 10⁶ m, far below any tracker."""


class SolverError(RuntimeError):
    """The equilibrium equation has no solution the solver can find (a load beyond what the arm holds)."""


@dataclass(frozen=True)
class SpringLinkage:
    """A planar spring linkage acting on one joint (Klimchik et al., eqs 4-7), with its own force law.

    Parameters
    ----------
    joint
        Index (0-based) of the joint it acts on.
    L, a_x, a_y, phi
        Lever length, projections of the pivot distance and lever angle at zero
        joint angle (m, m, m, rad), with the convention of
        ``bayescal.robot.compensator``: the lever is at ``phi - q`` at joint angle ``q``.
    K_c, s0
        Spring rate (N/m) and free length (m).
    progression
        Relative rise of the rate over a stretch of ``stroke``: the force is
        ``K_c·x·(1 + progression·x/stroke)``, ``x = s - s0`` (0: a linear spring).
    stroke
        Reference stretch (m) of the progression.
    """

    joint: int
    L: float
    a_x: float
    a_y: float
    phi: float
    K_c: float
    s0: float
    progression: float = 0.0
    stroke: float = 0.2

    def length(self, angle: float) -> float:
        """Spring length (m) at the link angle ``angle`` (rad): the law of cosines of eq 4."""
        a = math.hypot(self.a_x, self.a_y)
        gamma = self.phi - math.atan2(self.a_y, self.a_x) - angle
        return math.sqrt(a * a + self.L * self.L + 2.0 * a * self.L * math.cos(gamma))

    def force(self, angle: float) -> float:
        """Spring force (N, positive stretched) at the link angle ``angle`` (rad)."""
        stretch = self.length(angle) - self.s0
        return self.K_c * stretch * (1.0 + self.progression * stretch / self.stroke)

    def moment(self, angle: float) -> float:
        """The moment ``M_c`` (N·m) of eq 7: force times its lever ``a·L·sin(γ)/s`` about the joint."""
        a = math.hypot(self.a_x, self.a_y)
        gamma = self.phi - math.atan2(self.a_y, self.a_x) - angle
        return self.force(angle) * a * self.L * math.sin(gamma) / self.length(angle)


@dataclass(frozen=True)
class Load:
    """A load on the tool: a force at a material point plus a dead couple, SI.

    Attributes
    ----------
    force : numpy.ndarray
        (3,) N, base axes; it keeps its direction as the tool moves (a hanging weight).
    point : numpy.ndarray
        (3,) flange-frame point where the force acts, m.
    couple : numpy.ndarray
        (3,) N·m, base axes, fixed.
    """

    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    couple: np.ndarray = field(default_factory=lambda: np.zeros(3))


def scaled_robot(robot: Robot, mass_scale: float) -> Robot:
    """A copy of ``robot`` whose link masses and rotational inertias are multiplied by ``mass_scale``.

    The centres of mass are kept: a uniformly denser casting, the simplest form of
    a URDF whose masses are off by one factor.  A weighed tool's mass is kept.
    """
    return robot.with_model(scaled_links(robot, mass_scale))


@dataclass(frozen=True, eq=False)
class Statics:
    """The arm's static equilibrium under loads: one robot, its joint springs and its spring linkage.

    Parameters
    ----------
    robot
        Kinematics and link masses (one :class:`Robot` per task: it holds Pinocchio's data).
    law
        Deflection law of the joint springs: (nq,) torques (N·m) → (nq,) deflections (rad).
    linkage
        The gravity compensator, if any.
    """

    robot: Robot
    law: Callable[[np.ndarray], np.ndarray]
    linkage: SpringLinkage | None = None

    def torque(self, q_link: np.ndarray, loads: list[Load]) -> np.ndarray:
        """(nq,) generalized force (N·m) that the joint springs carry with the links at ``q_link`` (rad)."""
        tau = -self.robot.gravity_torque(q_link)
        if self.linkage is not None:
            tau[self.linkage.joint] -= self.linkage.moment(float(q_link[self.linkage.joint]))
        for load in loads:
            tau += self.robot.point_jacobian(q_link, load.point).T @ load.force
            if np.any(load.couple):
                tau += self.robot.flange_jacobian(q_link)[3:].T @ load.couple
        return tau

    def solve(self, q, loads: list[Load], lost_motion=None) -> tuple[np.ndarray, np.ndarray]:
        """Spring deflections ``θ`` (rad) and torques ``τ`` (N·m) at equilibrium, links at ``q + θ + lost_motion``.

        Parameters
        ----------
        q
            (nq,) commanded joint angles, rad.
        loads
            Loads on the tool (may be empty: the arm under its own weight).
        lost_motion
            (nq,) gear play taken up (rad), or None.

        Raises
        ------
        SolverError
            When no equilibrium is found to :data:`_RESIDUAL_TOLERANCE`.
        """
        q = np.asarray(q, dtype=float)
        offset = q if lost_motion is None else q + np.asarray(lost_motion, dtype=float)

        def residual(theta: np.ndarray) -> np.ndarray:
            return theta - self.law(self.torque(offset + theta, loads))

        start = self.law(self.torque(offset, loads))
        solution = root(residual, start, method="hybr", options={"xtol": 1e-15})
        theta = solution.x
        if not np.all(np.isfinite(theta)) or np.max(np.abs(residual(theta))) > _RESIDUAL_TOLERANCE:
            raise SolverError(f"no static equilibrium found ({solution.message.strip()})")
        return theta, self.torque(offset + theta, loads)
