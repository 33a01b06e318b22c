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
on the arm's weight alone; :func:`compensate_poses` gives both steps, and the
tests check the loaded equilibrium at ``q_c`` (the full solve of
:class:`~bayescal.robot.stiffness.ElasticArm`) lands on ``λ``.

The error left at a pose is what a posterior draw would deflect the tool more
than the mean (:mod:`bayescal.compensation.spread`); its rms is eq 38.
"""

from __future__ import annotations

import numpy as np

from bayescal.cell.config import Cell
from bayescal.compensation.calibration import Calibration
from bayescal.compensation.program import Program
from bayescal.compensation.results import CompensationResults
from bayescal.compensation.spread import deflection_draws, designs, error_quantiles, mean_square
from bayescal.inference.exact import scale_masses
from bayescal.robot.compensator import Compensator
from bayescal.robot.kinematics import Robot

__all__ = ["compensate_program", "compensate_poses", "predicted_errors", "unloaded_links"]

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
    joint = calibration.compensated_joint
    full = _Spread(calibration.compliances(q_compensated), joint)
    held = _Spread(calibration.compliances(q_compensated, fixed=calibration.unidentified), joint) if calibration.unidentified else None
    for start in range(0, design.shape[0], CHUNK):
        part = slice(start, start + CHUNK)
        spread, mean = full(design[part], q_compensated[part])
        stats = error_quantiles(np.sqrt(np.einsum("pis,pis->ps", spread, spread)))
        share = np.zeros(len(mean))
        if held is not None:
            rest, total = held.mean_square(design[part], q_compensated[part]), stats["rms"] ** 2
            share = np.clip(1.0 - np.divide(rest, total, out=np.ones_like(total), where=total > 0), 0.0, 1.0)
        for name, value in (*stats.items(), ("mean_compliances", mean), ("unidentified_share", share)):
            out[name].append(value)
    return {name: np.concatenate(values) for name, values in out.items()}


class _Spread:
    """The draws' deflections about their mean at a chunk of poses: ``(p, 3, S)`` and the ``(p, n)`` mean compliances."""

    def __init__(self, compliances, joint: int | None) -> None:
        self.own, self.equivalent = compliances
        self.centred = self.own - self.own.mean(axis=0)
        self.joint = joint

    def _varying(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        mean = np.repeat(self.own.mean(axis=0)[None, :], len(angles), axis=0)
        if self.equivalent is None:
            return mean, None
        varying = self.equivalent(angles)
        mean[:, self.joint] = varying.mean(axis=1)
        return mean, varying - mean[:, self.joint, None]

    def __call__(self, design: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        mean, varying = self._varying(angles)
        return deflection_draws(design, self.centred, varying, self.joint), mean

    def mean_square(self, design: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """``(p,)`` mean-square deflection about the mean (m²), from the draws' covariance."""
        return mean_square(design, self.centred, self._varying(angles)[1], self.joint)


def unloaded_links(
    robot: Robot, q: np.ndarray, own: np.ndarray, compensator: Compensator | None, joint: int | None, *, max_iter: int = 20
) -> tuple[np.ndarray, np.ndarray]:
    """``(P, n)`` link angles ``q + θ`` (rad) of the arm at poses ``q`` under its weight and the compensator, no wrench.

    Newton's method (its chord form) on ``θ = k ∘ τ(q + θ)`` with ``τ = -g - M_c e_c`` (linear
    joints of own compliances ``own`` ``(P, n)``, rad/(N·m)), all poses at once, converged to
    :data:`EQUILIBRIUM_TOL`.  Also returns ``(P,)`` True where a pose did not converge (its links NaN).
    """
    P, n = q.shape
    # The derivative (gravity's Hessian term and the compensator's stiffness) is taken once, at q: the
    # deflections are small, so the chord steps converge about a thousandfold per step at a third of the cost.
    derivative = -np.stack([robot.gravity_torque_derivative(qi) for qi in q])
    if joint is not None:
        derivative[:, joint, joint] -= compensator.stiffness(q[:, joint])
    chord = np.eye(n) - own[:, :, None] * derivative
    theta = np.zeros((P, n))
    active = np.arange(P)
    for _ in range(max_iter):
        links = q[active] + theta[active]
        torque = -np.stack([robot.gravity_torque(li) for li in links])
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
    torque = np.full_like(q, np.nan)
    for p in np.flatnonzero(~failed):
        torque[p] = robot.flange_jacobian(links[p]).T @ wrench[p] - robot.gravity_torque(links[p])
    if joint is not None:
        torque[:, joint] -= compensator.torque(links[:, joint])
    return links - own * torque, links, failed


def compensate_program(
    program: Program, calibration: Calibration, cell: Cell, *, tolerance: float | None = None
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
    """
    robot = scale_masses(cell.robot, calibration.gravity_scale) if calibration.gravity_scale != 1.0 else cell.robot
    joint = cell.compensated_joint
    rotations = np.stack([robot.flange_pose(qi)[0] for qi in program.q])
    wrench = program.flange_wrench(rotations)
    design = designs(robot, program.q, program.tcp, wrench)
    q_comp = program.q[:, joint] if joint is not None else np.zeros(len(program))
    errors = predicted_errors(calibration, design, q_comp)
    compensator = calibration.mean_compensator()
    mean = errors["mean_compliances"]
    own = np.repeat(calibration.own.mean(axis=0)[None, :], len(program), axis=0)
    if joint is not None:
        # The compensation applies the draws' mean equivalent compliance (the mean of eq 8's draws).
        own[:, joint] = compensator.own_compliance(q_comp, mean[:, joint])
    deflection = np.linalg.norm(np.einsum("pin,pn->pi", design, mean), axis=1)
    commands, _, failed = compensate_poses(robot, program.q, wrench, own, compensator, joint)
    return CompensationResults(
        program=program,
        robot=cell.robot,
        commands=commands,
        deflection=deflection,
        errors={name: errors[name] for name in ("rms", "q95", "q9973")},
        unidentified_share=errors["unidentified_share"],
        unidentified=calibration.unidentified,
        failed=failed,
        tolerance=tolerance,
        n_draws=calibration.n_draws,
    )
