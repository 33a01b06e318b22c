"""Compliance error compensation of a machining program, with the error each pose still carries.

For each pose the programmed joints ``q`` put the unloaded tool (the arm
under its own weight and the compensator, eq 1 with no wrench) at a pose
``T(q)``.  Under the process wrench the tool deflects; the compensated
targets ``q_c`` are those at which the loaded arm puts the tool at ``T(q)``:
the dual of eq 2.  They are found with the posterior-mean parameters, from
the linear map of eq 31 (``q_c0 = q - J⁻¹ δ``) and one Newton step with the
exact model (two static equilibria of :class:`~bayescal.robot.stiffness.ElasticArm`),
which :func:`compensate_pose` can repeat to convergence to check it.  With
six joints the tool's whole pose is kept; with fewer, its position first,
then as much of its orientation as the remaining joints allow; with more,
the smallest joint correction.

The error left at a pose is what a posterior draw would deflect the tool more
than the mean (:mod:`bayescal.compensation.spread`); its rms is eq 38.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from bayescal.cell.config import Cell
from bayescal.compensation.calibration import Calibration
from bayescal.compensation.program import Program
from bayescal.compensation.results import CompensationResults
from bayescal.compensation.spread import deflection_draws, designs, error_quantiles
from bayescal.inference.exact import scale_masses
from bayescal.robot.kinematics import Robot
from bayescal.robot.stiffness import ElasticArm, EquilibriumError

__all__ = ["compensate_program", "compensate_pose", "predicted_errors"]

CHUNK = 256
"""Poses whose draws are spread at once: ``S × CHUNK × n`` compliances in memory."""

EQUILIBRIUM_TOL = 1e-10
"""Newton tolerance of the equilibria, rad: 1e-10 rad moves a tool 3 m out by 0.3 nm."""


def predicted_errors(calibration: Calibration, design: np.ndarray, q_compensated: np.ndarray) -> dict[str, np.ndarray]:
    """Error left at each pose after compensation with the posterior mean, over the draws (m).

    Parameters
    ----------
    calibration
        The posterior draws.
    design
        ``(P, 3, n)`` eq-31 matrices of the poses.
    q_compensated
        ``(P,)`` angle of the compensated joint at each pose, rad.

    Returns
    -------
    dict
        ``rms``, ``q95``, ``q9973`` ``(P,)`` (m); ``mean_compliances`` ``(P, n)``, the compliances the
        compensation applies; ``unidentified_share`` ``(P,)``, the fraction of the mean-square error
        that the parameters the campaign did not identify account for.
    """
    out: dict[str, list] = {"rms": [], "q95": [], "q9973": [], "mean_compliances": [], "unidentified_share": []}
    for start in range(0, design.shape[0], CHUNK):
        part = slice(start, start + CHUNK)
        k = calibration.compliances(q_compensated[part])
        mean = k.mean(axis=0)
        spread = deflection_draws(design[part], k - mean)
        stats = error_quantiles(np.linalg.norm(spread, axis=-1))
        share = np.zeros(spread.shape[1])
        if calibration.unidentified:
            fixed = calibration.compliances(q_compensated[part], fixed=calibration.unidentified)
            rest = deflection_draws(design[part], fixed - fixed.mean(axis=0))
            full = np.mean(np.sum(spread**2, axis=-1), axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                share = np.clip(1.0 - np.mean(np.sum(rest**2, axis=-1), axis=0) / full, 0.0, 1.0)
            share = np.nan_to_num(share)
        for name, value in (*stats.items(), ("mean_compliances", mean), ("unidentified_share", share)):
            out[name].append(value)
    return {name: np.concatenate(values) for name, values in out.items()}


def tool_pose(robot: Robot, q: np.ndarray, tcp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``(3, 3)`` of the flange and position ``(3,)`` of the tool point (m) at links ``q``."""
    rotation, _ = robot.flange_pose(q)
    return rotation, robot.point_position(q, tcp)


def tool_jacobian(robot: Robot, q: np.ndarray, tcp: np.ndarray) -> np.ndarray:
    """``(6, n)`` Jacobian of the tool point's position and the flange's rotation (base axes)."""
    return np.vstack([robot.point_jacobian(q, tcp), robot.flange_jacobian(q)[3:]])


def correction(jacobian: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Joint step ``(n,)`` that removes a ``(6,)`` pose error ``[δp (m); δφ (rad)]``, position first.

    The position is removed in the least-squares sense by the minimum-norm step; the
    orientation then with what the null space of the position rows leaves (all of it
    for six joints, part of it for fewer).
    """
    Jp, Jr = jacobian[:3], jacobian[3:]
    Jp_pinv = np.linalg.pinv(Jp)
    step = Jp_pinv @ error[:3]
    null = np.eye(jacobian.shape[1]) - Jp_pinv @ Jp
    return step + null @ np.linalg.pinv(Jr @ null, rcond=1e-8) @ (error[3:] - Jr @ step)


def compensate_pose(
    arm: ElasticArm, q: np.ndarray, tcp: np.ndarray, wrench: np.ndarray, start: np.ndarray, *, steps: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Compensated joints from ``start`` by ``steps`` Newton steps of the exact model.

    Parameters
    ----------
    arm
        The arm with the parameters to compensate with.
    q
        ``(n,)`` programmed joints, rad.
    tcp
        ``(3,)`` tool point in the flange frame, m.
    wrench
        ``(6,)`` process wrench at the flange origin, base axes.
    start
        ``(n,)`` first guess (the linear map's), rad.
    steps
        Newton steps.

    Returns
    -------
    tuple
        ``(n,)`` compensated joints and the ``(6,)`` pose error ``[m; rad]`` the last step removed.
    """
    robot = arm.robot
    target_rotation, target = tool_pose(robot, q + arm.equilibrium(q, np.zeros(6), tol=EQUILIBRIUM_TOL), tcp)
    command = np.array(start, dtype=float)
    error = np.zeros(6)
    for _ in range(steps):
        links = command + arm.equilibrium(command, wrench, tol=EQUILIBRIUM_TOL)
        rotation, position = tool_pose(robot, links, tcp)
        error = np.concatenate([position - target, pin.log3(rotation @ target_rotation.T)])
        command = command - correction(tool_jacobian(robot, links, tcp), error)
    return command, error


def compensate_program(
    program: Program, calibration: Calibration, cell: Cell, *, tolerance: float | None = None, steps: int = 1
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
    steps
        Newton steps of the exact model after the linear map.
    """
    robot = scale_masses(cell.robot, calibration.gravity_scale) if calibration.gravity_scale != 1.0 else cell.robot
    joint = cell.compensated_joint
    rotations = np.stack([robot.flange_pose(qi)[0] for qi in program.q])
    wrench = program.flange_wrench(rotations)
    design = designs(robot, program.q, program.tcp, wrench)
    q_comp = program.q[:, joint] if joint is not None else np.zeros(len(program))
    errors = predicted_errors(calibration, design, q_comp)
    compensator = calibration.mean_compensator()
    own = calibration.own.mean(axis=0)
    commands = np.full_like(program.q, math.nan)
    deflection = np.full((len(program), 6), math.nan)
    newton = np.full(len(program), math.nan)
    failed = np.zeros(len(program), dtype=bool)
    for p, (q, tcp, w, k) in enumerate(zip(program.q, program.tcp, wrench, errors["mean_compliances"])):
        pose_own = own.copy()
        if joint is not None:
            # The compensation applies the draws' mean equivalent compliance (the mean of eq 8's draws).
            pose_own[joint] = compensator.own_compliance(q[joint], k[joint])
        arm = ElasticArm.linear(robot, pose_own, compensator=compensator)
        jacobian = tool_jacobian(robot, q, tcp)
        deflection[p] = jacobian @ (k * (robot.flange_jacobian(q).T @ w))
        try:
            commands[p], last = compensate_pose(arm, q, tcp, w, q - correction(jacobian, deflection[p]), steps=steps)
        except EquilibriumError:
            failed[p] = True
            continue
        newton[p] = np.linalg.norm(last[:3])
    return CompensationResults(
        program=program,
        robot=cell.robot,
        commands=commands,
        deflection=np.linalg.norm(deflection[:, :3], axis=1),
        errors={name: errors[name] for name in ("rms", "q95", "q9973")},
        unidentified_share=errors["unidentified_share"],
        unidentified=calibration.unidentified,
        newton_correction=newton,
        failed=failed,
        tolerance=tolerance,
        n_draws=calibration.n_draws,
    )
