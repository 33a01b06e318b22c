"""The exact elastostatic model: deflections between two static equilibria of the arm.

The linear model of eq 30 takes the deflection as ``A k``.  The exact model
computes it as the difference between the loaded and the unloaded static
equilibria of the virtual-joint model with the links' weight and the
compensator (eqs 1-3, 8).  The identification relinearises: the difference
between the exact and the linear prediction at the current estimate is
subtracted from the measured deflections and the linear problem solved again
(:class:`ExactCorrection`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.inference.closedform import ClosedForm, closed_form
from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.identifiability import Identifiability
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.compensator import law_on
from bayescal.robot.laws import CompensatorLaw
from bayescal.robot.kinematics import Robot, scaled_links
from bayescal.robot.stiffness import ElasticArm

__all__ = ["ExactCorrection", "campaign_deflections", "exact_deflections", "linearisation_offset", "moved_point", "scale_masses"]

STATIC_STEPS = (0.05, 0.05, 0.05)
"""Finite-difference steps of the static columns: relative in the law's static coordinates (K_c and K_c s0 for the
spring), absolute in the mass scale; the correction is linear in all three to well within this (the spring's torque
is linear in K_c and K_c s0, eq 7)."""


SETTLED_SD = 3.0
"""Distance (posterior sd of ``K_c``, ``K_c s0`` or the mass scale) beyond which the correction is linearised again about
the posterior mean.  The linearisation itself holds far: with the spring 4.6 times the config's, 340 posterior sd of
K_c away at 0.3 μm, it missed the correction by 0.017 μm rms and moved K_c by 0.7 sd.  What fails that far is the
start of the chains (:meth:`~bayescal.inference.elastostatic.ElastostaticModel.fit`).  Of 40 campaigns simulated with
the config's own values (random plans of 6 × 5 configurations, 8 μm, seeds 100-139), 3 were relinearised under this
rule and :data:`UNCONVERGED_SD`'s (2 under this one alone); all 40 converged."""
UNCONVERGED_SD = 0.5
""":data:`SETTLED_SD` after a run whose chains disagree: there the start may be what failed, and a mean half an sd away
is a better one (the link masses 15 % heavier than the URDF's at 0.3 μm: R-hat 1.010 after every extension without)."""


def moved_point(spring: np.ndarray, masses: np.ndarray, at: np.ndarray, tolerance: float = SETTLED_SD, law: CompensatorLaw | None = None) -> tuple[float, ...] | None:
    """Where to linearise the correction next: None when the posterior mean of the law's static coordinates and the
    mass scale (``[K_c, K_c s0, mass scale]`` for the spring) lies within ``tolerance`` posterior sd of the
    linearisation point ``at``, otherwise that mean.

    Parameters
    ----------
    spring
        ``(..., 1 + p)`` draws of ``[K_theta2^0, *law values]`` (``K_c``, ``s0`` in N/m, m for the spring).
    masses
        ``(...)`` draws of the link-mass scale.
    at
        ``(p + 1,)`` the point the correction was linearised about (:meth:`ExactCorrection.static_columns`).
    tolerance
        :data:`SETTLED_SD`, or :data:`UNCONVERGED_SD` for draws whose chains disagree.
    law
        The compensator's law; None: the spring of eqs 4-9.

    Returns
    -------
    tuple or None
        ``(*law values, mass scale)`` (SI, 1) at the posterior mean of the static coordinates, or None.
    """
    # The spring's static coordinates do not depend on its geometry: any valid one stands in for None's.
    law = law_on(law, (1.0, 2.0, 0.0, 0.0))
    u = law.static_point(spring[..., 1:].reshape(-1, spring.shape[-1] - 1))
    values = np.column_stack([u, masses.reshape(-1)])
    mean, sd = values.mean(axis=0), values.std(axis=0)
    if np.all(np.abs(mean - at) <= tolerance * sd):
        return None
    return (*law.from_static(mean[:-1]), float(mean[-1]))


def exact_deflections(
    robot: Robot,
    q: np.ndarray,
    wrench: np.ndarray,
    compliances: np.ndarray,
    compensator: CompensatorLaw | None,
    *,
    points_in_flange: np.ndarray | None = None,
    unloaded_positions: np.ndarray | None = None,
    load_point: np.ndarray | None = None,
    compensated_joint: int | None = None,
) -> np.ndarray:
    """Deflections (m) of tool points between the unloaded and the loaded static equilibria.

    Both equilibria include the links' weight and the compensator; the loaded
    one adds ``wrench``.  The points are given either in the flange frame or by
    their measured unloaded positions in the base frame (then located on the
    tool at the unloaded equilibrium).

    Parameters
    ----------
    robot
        The robot.
    q
        ``(nq,)`` commanded joint angles (rad).
    wrench
        ``(6,)`` load at the flange origin in base axes (N, N·m), as applied at ``q``.
    compliances
        ``(nq,)`` joint compliances (rad/(N·m)); the compensated joint's is ``1/K_theta2^0``.
    compensator
        The compensator, on the joint ``compensated_joint`` (0-based; required with a compensator).
    points_in_flange, unloaded_positions
        ``(k, 3)`` points, one of the two (m).
    load_point
        Flange-frame point where the load's force acts (a hanging mass); None: flange origin, dead load.
    """
    arm = ElasticArm.linear(robot, compliances, compensator=compensator, load_point=load_point, compensated_joint=compensated_joint)
    unloaded = q + arm.equilibrium(q, np.zeros(6))
    loaded = q + arm.equilibrium(q, wrench)
    workspace = robot.workspace()
    if points_in_flange is None:
        points_in_flange = workspace.point_in_flange(unloaded, unloaded_positions)
    return workspace.point_position(loaded, points_in_flange) - workspace.point_position(unloaded, points_in_flange)


def scale_masses(robot: Robot, factor: float) -> Robot:
    """A copy of ``robot`` with every link's mass and rotational inertia multiplied by ``factor``; a weighed tool's
    (:meth:`~bayescal.robot.kinematics.Robot.with_tool`) is kept."""
    return robot.with_model(scaled_links(robot, factor))


def campaign_deflections(
    robot: Robot,
    campaign: Campaign,
    equations: DeflectionEquations,
    compliances: np.ndarray,
    k2: np.ndarray,
    compensator: CompensatorLaw | None,
    load_point: np.ndarray | None,
) -> np.ndarray:
    """``(N, 3)`` exact deflections (m) of every row of ``campaign``, all configurations solved together.

    What :func:`exact_deflections` gives one configuration at a time, from the
    unloaded and loaded equilibria of every configuration at once
    (:func:`~bayescal.robot.batched.equilibria`); arguments as :func:`linearisation_offset`'s.
    """
    configs, first, row_config = np.unique(campaign.config, return_index=True, return_inverse=True)
    q = campaign.q[first]
    k = np.repeat(np.asarray(compliances, dtype=float)[None, :], configs.size, axis=0)
    if equations.joint is not None:
        angle = equations.angle[::3][first]
        k[:, equations.joint] = compensator.own_compliance(q[:, equations.joint], k2[angle])
    points = load_point if campaign.load_point is None else campaign.load_point[first]
    chain = BatchedChain.of(robot)
    solve = partial(equilibria, chain, q, compliances=k, compensator=compensator, compensated_joint=equations.joint, load_point=points)
    unloaded = chain.poses(q + solve(np.zeros(6)))
    loaded = chain.poses(q + solve(campaign.wrench[first]))
    # Each marker located on the tool at its configuration's unloaded equilibrium, as exact_deflections does.
    on_tool = unloaded.in_flange(campaign.p0, row_config)
    return loaded.points(on_tool, row_config) - unloaded.points(on_tool, row_config)


def linearisation_offset(
    robot: Robot,
    campaign: Campaign,
    equations: DeflectionEquations,
    compliances: np.ndarray,
    k2: np.ndarray,
    compensator: CompensatorLaw | None,
    load_point: np.ndarray | None,
) -> np.ndarray:
    """Exact minus linear prediction (m) of every equation of ``campaign``.

    Parameters
    ----------
    robot, campaign, equations
        The robot, the campaign and its equations.
    compliances
        ``(nq,)`` joint compliances (rad/(N·m)); the compensated joint's entry is not used.
    k2
        ``(m,)`` equivalent compliance of the compensated joint at each of the equations' angles
        (``(0,)`` without a compensator).
    compensator
        The compensator whose static torque sets the unloaded and loaded equilibria; None when the
        robot has none (``equations.joint`` None).
    load_point
        Flange-frame point where the load's force acts when the campaign gives
        none (its ``load_point`` columns take precedence); None: flange origin, dead load.
    """
    exact = campaign_deflections(robot, campaign, equations, compliances, k2, compensator, load_point)
    per_row = np.repeat(np.asarray(compliances, dtype=float)[None, :], equations.n, axis=0)
    if equations.joint is not None:
        per_row[:, equations.joint] = k2[equations.angle]
    return exact.reshape(-1) - np.einsum("ij,ij->i", equations.design, per_row)


@dataclass(frozen=True)
class ExactCorrection:
    """The exact model's correction of a campaign's linear equations, at a closed-form estimate.

    Parameters
    ----------
    robot
        The robot (its URDF gives the link masses).
    nominal_compliances
        ``(nq,)`` compliances (rad/(N·m)) for the parameters the campaign cannot identify.
    geometry_mean
        The compensator geometry ``[L, a_x, a_y, phi]`` (m, rad); None without a compensator.
    nominal_spring
        The law's values (SI; ``(K_c, s0)`` in N/m, m for the spring) of the compensator's static torque about which
        the correction is linearised (the config's, or the posterior's when that is far from it); None without a
        compensator.
    load_point
        Flange-frame point (m) where the load's force acts.
    max_iterations
        Relinearisations before :meth:`relinearise` gives up with a warning.
    masses
        Scale on the URDF's link masses about which the correction is linearised.
    law
        The compensator's law (its constants); None: the spring of eqs 4-9.
    """

    robot: Robot
    nominal_compliances: np.ndarray
    geometry_mean: np.ndarray | None
    nominal_spring: tuple[float, float] | None
    load_point: np.ndarray | None
    max_iterations: int = 10
    masses: float = 1.0
    law: CompensatorLaw | None = None

    def _law(self) -> CompensatorLaw | None:
        """The law at the linearisation point's values (where a regressor that depends on them starts)."""
        return None if self.law is None else law_on(self.law, self.geometry_mean, self.nominal_spring)

    def _robot(self, masses: float | None = None) -> Robot:
        """The robot with its link masses scaled by ``masses`` (default: the linearisation point's)."""
        factor = self.masses if masses is None else masses
        return self.robot if factor == 1.0 else scale_masses(self.robot, factor)

    def offset(self, campaign: Campaign, equations: DeflectionEquations, cf: ClosedForm, *, spring=None, robot: Robot | None = None) -> np.ndarray:
        """Exact minus linear prediction of every equation at the closed-form estimate ``cf``.

        The per-angle joint-2 compliances of ``cf`` fix joint 2's stiffness at each
        angle; the compensator's static torque, which with the arm's weight sets
        the sag under which the loads act, is that of the law's values ``spring`` (``(K_c, s0)``)
        (default: the linearisation point's), and the weights those of ``robot`` (default:
        the URDF's scaled by the linearisation point's ``masses``).  The compensated model
        corrects both through :meth:`static_columns`.
        """
        robot = robot or self._robot()
        compliances = np.where(np.isfinite(cf.compliances) & (cf.compliances > 0), cf.compliances, self.nominal_compliances)
        if equations.joint is None:
            return linearisation_offset(robot, campaign, equations, compliances, cf.k2, None, self.load_point)
        compensator = law_on(self.law, self.geometry_mean, spring or self.nominal_spring)
        nominal_k2 = compensator.equivalent_compliance(equations.compensated_angles, self.nominal_compliances[equations.joint])
        k2 = np.where(np.isfinite(cf.k2) & (cf.k2 > 0), cf.k2, nominal_k2)
        return linearisation_offset(robot, campaign, equations, compliances, k2, compensator, self.load_point)

    def static_columns(self, campaign: Campaign, equations: DeflectionEquations, cf: ClosedForm, base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The exact model's correction linearised in the compensator's static torque and the link weights.

        Returns the linearisation point ``[*static coordinates, mass scale]`` (for the spring ``[K_c, K_c s0, mass
        scale]``, N/m, N, 1) and the ``(n, p + 1)`` derivatives of the correction with respect to each static
        coordinate (``K_c`` at fixed ``K_c s0``, then ``K_c s0``) and a common scale of the link masses, by finite
        differences, divided like the equations by their relative noise.  The derivatives are taken at the closed form ``cf`` the
        offset ``base`` was computed at, so that the offset itself is their base.
        """
        law = law_on(self.law, self.geometry_mean, self.nominal_spring)
        dg = STATIC_STEPS[-1]
        columns = [
            (self.offset(campaign, equations, cf, spring=values) - base) / step
            for step, values in law.static_steps(self.nominal_spring, STATIC_STEPS[:-1])
        ]
        columns.append((self.offset(campaign, equations, cf, robot=self._robot(self.masses + dg)) - base) / dg)
        W = np.column_stack(columns)
        if equations.scale is not None:
            W = W / equations.scale[:, None]
        return np.array([*law.static_point(self.nominal_spring), self.masses]), W

    def relinearise(self, campaign: Campaign, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm):
        """The closed form of the corrected equations, relinearised until it no longer moves.

        Returns the closed form, the ``(n,)`` offset (m), the iterations run and the
        closed form the offset was computed at.
        """
        sd = np.sqrt(np.diag(cf.cov))
        offset = np.zeros(equations.n)
        for iteration in range(1, self.max_iterations + 1):
            at = cf
            offset = self.offset(campaign, equations, at)
            updated = closed_form(replace(equations, y=equations.y - offset).whitened(), ident, self.geometry_mean, self._law())
            change = np.abs(updated.per_angle - cf.per_angle)
            moved = float(np.max(change / sd))
            cf = updated
            if moved < 1e-3 or np.all(change <= 1e-9 * np.abs(cf.per_angle)):
                return cf, offset, iteration, at
        warnings.warn(
            f"the exact model did not settle in {self.max_iterations} relinearisations (last move {moved:.2g} sd)",
            UserWarning,
            stacklevel=3,
        )
        return cf, offset, self.max_iterations, at
