"""Compliance error compensation of a machining program, with the error each pose still carries.

For each pose the programmed joints ``q`` put the unloaded arm (under its own
weight and the compensator: eq 1 with no wrench) at link angles
``λ = q + θ(q, 0)``, and the tool at ``T(λ)``.  The compensated targets ``q_c``
are those at which the arm loaded by the process wrench puts the tool at the
same ``T(λ)``: the dual of eq 2.  Asking the loaded links to be ``λ`` itself
keeps the whole tool pose, position and orientation, for any number of joints,
and turns the dual problem into one evaluation: at links ``λ`` the joint springs
carry the known torque ``τ(λ) = -g(λ) - M_c(λ) e_c + J(λ)ᵀ w``, so the actuators
must stand at ``q_c = λ - D(τ(λ))`` (eq 1 read backwards, ``D`` the joint
deflection law).  The only solve is the unloaded equilibrium, Newton's method
on the arm's weight alone; :func:`compensate_poses` gives both steps, for all
poses at once on the fit's engine (:class:`~bayescal.robot.batched.BatchedChain`: the
kinematics, Jacobians and gravity torques of every pose as stacked arrays), and the
tests check the loaded equilibrium at ``q_c`` (the full solve of
:class:`~bayescal.robot.stiffness.ElasticArm`) lands on ``λ``.

The correction applies the draws' median of each parameter; the error left at
a pose is what a draw would deflect the tool more than that
(:mod:`bayescal.compensation.budget`); its rms is eq 38.
"""

from __future__ import annotations

import numpy as np

from bayescal.cell.config import Cell
from bayescal.compensation.calibration import Calibration
from bayescal.compensation.program import Program
from bayescal.compensation.results import CompensationResults
from bayescal.compensation.budget import error_budget
from bayescal.compensation.spread import designs
from bayescal.inference.exact import scale_masses
from bayescal.robot.batched import BatchedChain
from bayescal.robot.compensator import Compensator
from bayescal.robot.kinematics import Robot

__all__ = ["compensate_program", "compensate_poses", "unloaded_links"]

EQUILIBRIUM_TOL = 1e-10
"""Newton tolerance of the equilibria, rad: 1e-10 rad moves a tool 3 m out by 0.3 nm."""


def unloaded_links(
    robot: Robot, q: np.ndarray, own: np.ndarray, compensator: Compensator | None, joint: int | None, *, max_iter: int = 20
) -> tuple[np.ndarray, np.ndarray]:
    """``(P, n)`` link angles ``q + θ`` (rad) of the arm at poses ``q`` under its weight and the compensator, no wrench.

    Newton's method (its chord form) on ``θ = k ∘ τ(q + θ)`` with ``τ = -g - M_c e_c`` (linear
    joints of own compliances ``own`` ``(P, n)``, rad/(N·m)), all poses at once
    (:class:`~bayescal.robot.batched.BatchedChain`), converged to :data:`EQUILIBRIUM_TOL`.  Also returns ``(P,)``
    True where a pose did not converge (its links NaN).
    """
    P, n = q.shape
    chain = BatchedChain.of(robot)
    # The derivative (gravity's Hessian term and the compensator's stiffness) is taken once, at q: the
    # deflections are small, so the chord steps converge about a thousandfold per step at a third of the cost.
    derivative = -chain.gravity_torque(chain.poses(q))[1]
    if joint is not None:
        derivative[:, joint, joint] -= compensator.stiffness(q[:, joint])
    chord = np.eye(n) - own[:, :, None] * derivative
    theta = np.zeros((P, n))
    active = np.arange(P)
    for _ in range(max_iter):
        links = q[active] + theta[active]
        torque = -chain.gravity_torque(chain.poses(links))[0]
        if joint is not None:
            torque[:, joint] -= compensator.torque(links[:, joint])
        step = np.linalg.solve(chord[active], (own[active] * torque - theta[active])[..., None])[..., 0]
        theta[active] += step
        active = active[~(np.max(np.abs(step), axis=1) < EQUILIBRIUM_TOL)]
        if not active.size:
            break
    theta[active] = np.nan
    failed = np.zeros(P, dtype=bool)
    failed[active] = True
    return q + theta, failed


def compensate_poses(
    robot: Robot, q: np.ndarray, wrench: np.ndarray, own: np.ndarray, compensator: Compensator | None, joint: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compensated joints: the loaded arm's links at the unloaded arm's, pose by pose.

    Parameters
    ----------
    robot
        The robot (link masses as identified).
    q
        ``(P, n)`` programmed joints, rad.
    wrench
        ``(P, 6)`` process wrenches at the flange origin, base axes, N and N·m (dead loads).
    own
        ``(P, n)`` joint compliances, rad/(N·m); the compensated joint's without its compensator.
    compensator
        The compensator, or None.
    joint
        Its joint (0-based), or None.

    Returns
    -------
    tuple
        ``(P, n)`` compensated joints, ``(P, n)`` the links ``λ`` they hold under the wrench (rad),
        and ``(P,)`` True where the unloaded equilibrium was not found (NaN rows).
    """
    links, failed = unloaded_links(robot, q, own, compensator, joint)
    chain = BatchedChain.of(robot)
    # A pose whose unloaded equilibrium failed has NaN links, and so NaN torques and commands.
    poses = chain.poses(links)
    linear, angular = chain.point_jacobian(poses, poses.flange_origin)
    gravity, _ = chain.gravity_torque(poses)
    torque = np.einsum("pjc,pc->pj", linear, wrench[:, :3]) + np.einsum("pjc,pc->pj", angular, wrench[:, 3:]) - gravity
    if joint is not None:
        torque[:, joint] -= compensator.torque(links[:, joint])
    return links - own * torque, links, failed


def compensate_program(
    program: Program, calibration: Calibration, cell: Cell, *, tolerance: float | None = None, keep_spread: bool = False
) -> CompensationResults:
    """Compensated joint targets and the error left at every pose of ``program``.

    Parameters
    ----------
    program
        The machining program.
    calibration
        Posterior draws of the cell's parameters.
    cell
        The cell (robot and compensated joint).
    tolerance
        Error (m) a pose's 99.73 % bound may reach before it is flagged; None: no such flag.
    keep_spread
        Keep each draw's deflection about the applied one in the budget (``(P, 3, S)``: for a few poses).
    """
    robot = scale_masses(cell.robot, calibration.gravity_scale) if calibration.gravity_scale != 1.0 else cell.robot
    joint = cell.compensated_joint
    chain = BatchedChain.of(robot)
    poses = chain.poses(program.q)
    wrench = program.flange_wrench(poses.flange_rotation)
    design = designs(chain, program.q, program.tcp, wrench, poses=poses)
    q_comp = program.q[:, joint] if joint is not None else np.zeros(len(program))
    budget = error_budget(calibration, design, q_comp, keep_spread=keep_spread)
    compensator = calibration.median_compensator()
    applied = budget.applied
    own = np.repeat(calibration.applied_own[None, :], len(program), axis=0)
    if joint is not None:
        # The compensated joint's own compliance that, with the median compensator, gives the median
        # of the equivalent compliance's draws at the pose (eq 8).
        own[:, joint] = compensator.own_compliance(q_comp, applied[:, joint])
    deflection = np.einsum("pin,pn->pi", design, applied)
    commands, _, failed = compensate_poses(robot, program.q, wrench, own, compensator, joint)
    return CompensationResults(
        program=program,
        robot=cell.robot,
        commands=commands,
        deflection_xyz=deflection,
        budget=budget,
        failed=failed,
        tolerance=tolerance,
        n_draws=calibration.n_draws,
    )
