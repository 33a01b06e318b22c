"""The exact elastostatic model: deflections between two static equilibria of the arm.

The linear model of eq 30 takes the deflection as ``A k``.  The exact model
computes it as the difference between the loaded and the unloaded static
equilibria of the virtual-joint model with the links' weight and the
compensator (eqs 1-3, 8).  The identification relinearises: the difference
between the exact and the linear prediction at the current estimate is
subtracted from the measured deflections and the linear problem solved again.
"""

from __future__ import annotations

from functools import partial

import numpy as np
import pinocchio as pin

from bayescal.cell.campaign import Campaign
from bayescal.inference.equations import DeflectionEquations
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.compensator import Compensator
from bayescal.robot.kinematics import Robot
from bayescal.robot.stiffness import ElasticArm

__all__ = ["campaign_deflections", "exact_deflections", "linearisation_offset", "scale_masses"]


def exact_deflections(
    robot: Robot,
    q: np.ndarray,
    wrench: np.ndarray,
    compliances: np.ndarray,
    compensator: Compensator | None,
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
        The spring compensator, on the joint ``compensated_joint`` (0-based; required with a compensator).
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
    """A copy of ``robot`` with every link's mass and rotational inertia multiplied by ``factor``."""
    model = robot.model.copy()
    for i in range(1, model.njoints):
        inertia = model.inertias[i]
        model.inertias[i] = pin.Inertia(inertia.mass * factor, inertia.lever, inertia.inertia * factor)
    return Robot(model, flange=robot.flange, source=robot.source)


def campaign_deflections(
    robot: Robot,
    campaign: Campaign,
    equations: DeflectionEquations,
    compliances: np.ndarray,
    k2: np.ndarray,
    compensator: Compensator | None,
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
    compensator: Compensator | None,
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
