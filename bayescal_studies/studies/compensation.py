"""Does the compensation leave the error it predicts?  A check on the digital twin against its own truth.

A campaign is simulated with a truth (the cell's, or one drawn unlike it:
:class:`~bayescal_studies.studies.elastostatic_coverage.Truth`), identified with the
model of the unchanged cell, and a program of random machining poses and
wrenches compensated with that posterior.  The twin, built from the truth
with the process force acting at the tool point (a load that turns with the
tool, unlike the compensation's dead wrench), is then moved to the
compensated targets under each wrench; how far its tool lands from where the
unloaded tool is at the programmed joints is compared with the predicted
99.73 % bound, and with the miss without compensation.
"""

from __future__ import annotations

import dataclasses
import warnings
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.compensation.calibration import load_calibration
from bayescal.compensation.compensate import compensate_program
from bayescal.compensation.program import WRENCH_COLUMNS, Program
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import scale_masses
from bayescal.robot.stiffness import ElasticArm
from bayescal.sampling.protocol import Sampler
from bayescal_studies.studies.elastostatic_coverage import LIMIT_MARGIN, Truth, TruthSpread, random_plan
from bayescal.design.parallel import seeded_map
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import DEG

__all__ = ["random_program", "twin_misses", "compensation_check", "compensation_coverage", "draw_truth", "independent_misses", "independent_compensation_check"]

MAX_PROCESS_FORCE = 1500.0
"""Largest process force of a random program, N (milling and drilling of aircraft parts: hundreds of N to ~1 kN)."""

MAX_PROCESS_MOMENT = 100.0
"""Largest process moment about the tool point, N·m (a spindle's torque)."""


def random_program(cell: Cell, poses: int, rng: np.random.Generator) -> Program:
    """Random machining poses within the joint limits (:data:`LIMIT_MARGIN` clear, the wrist away from
    its singularity) and random wrenches up to :data:`MAX_PROCESS_FORCE` and :data:`MAX_PROCESS_MOMENT`."""
    robot = cell.robot
    low = robot.lower + LIMIT_MARGIN * (robot.upper - robot.lower)
    high = robot.upper - LIMIT_MARGIN * (robot.upper - robot.lower)
    q = rng.uniform(low, high, (poses, robot.nq))
    if robot.nq >= 5:
        # |q5| below 15 deg aligns joints 4 and 6: a singular wrist no machining program uses.
        q[:, 4] = np.where(np.abs(q[:, 4]) < 15 * DEG, np.sign(q[:, 4] + 1e-12) * 15 * DEG, q[:, 4])
    direction = rng.normal(size=(poses, 3))
    force = direction / np.linalg.norm(direction, axis=1, keepdims=True) * rng.uniform(0.2, 1.0, (poses, 1)) * MAX_PROCESS_FORCE
    moment = rng.uniform(-1.0, 1.0, (poses, 3)) * MAX_PROCESS_MOMENT / np.sqrt(3)
    wrench = np.column_stack([force, moment])
    table = pd.DataFrame(
        np.column_stack([q / DEG, wrench]),
        columns=[f"q{j + 1}_deg" for j in range(robot.nq)] + list(WRENCH_COLUMNS),
        index=pd.Index(np.arange(2, poses + 2), name="line"),
    ).map(lambda value: f"{value:.9g}")
    return Program(q=q, wrench=wrench, tcp=np.tile(cell.tool_point, (poses, 1)), table=table, source="random program")


def twin_misses(twin: Cell, program: Program, commands: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(P,)`` how far (m) the twin's loaded tool lands from its unloaded tool at the programmed joints,
    moved to ``commands`` and, for comparison, left at the programmed joints.

    The twin's arm is ``twin``'s (its compliances, spring and link masses) with the process force
    acting at the tool point.
    """
    robot = twin.robot
    misses = np.full((2, len(program)), np.nan)
    for p, (q, tcp, wrench, command) in enumerate(zip(program.q, program.tcp, program.wrench, commands)):
        arm = ElasticArm.linear(robot, twin.compliances, compensator=twin.compensator, compensated_joint=twin.compensated_joint, load_point=tcp)
        target = robot.point_position(q + arm.equilibrium(q, np.zeros(6)), tcp)
        for i, at in enumerate((command, q)):
            if not np.all(np.isfinite(at)):
                continue
            rotation, _ = robot.flange_pose(at)
            flange = np.concatenate([wrench[:3], wrench[3:] + np.cross(rotation @ tcp, wrench[:3])])
            misses[i, p] = np.linalg.norm(robot.point_position(at + arm.equilibrium(at, flange), tcp) - target)
    return misses[0], misses[1]


def _calibration(cell: Cell, campaign, rng: np.random.Generator, sampler: Sampler | None, folder):
    """The campaign's identification as compensate reads it: fitted, saved in ``folder`` and loaded back."""
    import tempfile
    from pathlib import Path

    options = {} if sampler is None else {"sampler": sampler}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, **options).fit(campaign, rng)
    with tempfile.TemporaryDirectory() as temporary:
        path = Path(folder or temporary) / "calibration.nc"
        results.save(path)
        return load_calibration(path, cell)


def compensation_check(
    cell: Cell,
    truth: Truth,
    plan: Plan,
    rng: np.random.Generator,
    *,
    poses: int = 200,
    repeats: int = 3,
    sampler: Sampler | None = None,
    folder=None,
) -> pd.DataFrame:
    """Calibrate on a campaign of ``plan`` simulated with ``truth``, compensate a random program, move the twin.

    Parameters
    ----------
    cell
        The cell as the user knows it (the model and the compensation are built from it).
    truth
        What the twin simulates.
    plan
        The campaign's plan.
    rng
        Every random draw.
    poses
        Poses of the random program.
    repeats
        Measurements per configuration.
    sampler
        The identification's sampler (default: the model's).
    folder
        Where the posterior file is written and read back (a temporary folder by default).

    Returns
    -------
    pandas.DataFrame
        Per pose: ``miss_m`` (compensated), ``uncompensated_m``, the predicted ``rms_m``,
        ``q9973_m``, and ``inside`` (miss within the 99.73 % bound).
    """
    twin = dataclasses.replace(
        cell,
        robot=scale_masses(cell.robot, truth.masses),
        compliances=truth.compliances,
        compensator=cell.compensator.geometry.with_spring(*truth.spring),
    )
    calibration = _calibration(cell, DigitalTwin(twin).simulate(plan, repeats, rng), rng, sampler, folder)
    program = random_program(cell, poses, rng)
    compensated = compensate_program(program, calibration, cell)
    miss, uncompensated = twin_misses(twin, program, compensated.commands)
    return pd.DataFrame(
        {
            "miss_m": miss,
            "uncompensated_m": uncompensated,
            "rms_m": compensated.errors["rms"],
            "q9973_m": compensated.errors["q9973"],
            "inside": miss <= compensated.errors["q9973"],
        }
    )


def draw_truth(cell: Cell, spread: TruthSpread | None, rng: np.random.Generator) -> Truth:
    """The cell's own values (``spread`` None), or a truth drawn unlike them as the elastostatic coverage study
    draws it (:meth:`~bayescal_studies.studies.elastostatic_coverage.TruthSpread.draw`)."""
    if spread is None:
        return Truth(compliances=cell.compliances, spring=(cell.compensator.K_c, cell.compensator.s0))
    return spread.draw(cell, rng)


def compensation_coverage(
    cell: Cell,
    campaigns: int,
    seed: int,
    *,
    plan: Plan | None = None,
    spread: TruthSpread | None = None,
    poses: int = 200,
    sampler: Sampler | None = None,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """:func:`compensation_check` over ``campaigns`` simulated calibrations, each with its own seed.

    Parameters
    ----------
    cell
        The cell as the user knows it.
    campaigns
        Number of campaigns.
    seed
        Root of every random draw.
    plan
        The campaigns' plan; None: a random plan of 6 q2 angles x 5 configurations per campaign.
    spread
        How far each truth is drawn from the cell's values; None: the cell's values are the truth.
    poses
        Poses of each campaign's random program.
    sampler
        The identification's sampler (default: the model's).
    executor
        Where the campaigns run; default a process pool on all cores (:func:`~bayescal.design.parallel.seeded_map`).

    Returns
    -------
    pandas.DataFrame
        :func:`compensation_check`'s rows with a ``campaign`` column.
    """
    frames = seeded_map(
        _campaign, range(campaigns), seed, executor=executor, cell=cell, plan=plan, spread=spread, poses=poses, sampler=sampler
    )
    return pd.concat(frames, ignore_index=True)


def _campaign(
    index: int, rng: np.random.Generator, cell: Cell, plan: Plan | None, spread: TruthSpread | None, poses: int, sampler
) -> pd.DataFrame:
    """One task of :func:`~bayescal.design.parallel.seeded_map`: campaign ``index`` of :func:`compensation_coverage`."""
    truth = draw_truth(cell, spread, rng)
    campaign_plan = plan if plan is not None else random_plan(cell, 6, 5, rng)
    return compensation_check(cell, truth, campaign_plan, rng, poses=poses, sampler=sampler).assign(campaign=index)


def independent_misses(cell: Cell, world, program: Program, commands: np.ndarray) -> np.ndarray:
    """``(P,)`` how far (m) the independent generator's loaded tool lands at ``commands`` from its unloaded tool
    at the programmed joints: its own statics (:class:`~bayescal.twin.independent.solver.Statics`, a root finder
    on its own spring linkage and joint law), its world's compliances, spring and link masses, the process force
    at the tool point and the program's moment as a dead couple."""
    from bayescal.twin.independent.solver import Load, SolverError, Statics, scaled_robot

    robot = scaled_robot(cell.robot, world.mass_scale)
    statics = Statics(robot, world.joint_law(), world.linkage)
    misses = np.full(len(program), np.nan)
    for p, (q, tcp, wrench, command) in enumerate(zip(program.q, program.tcp, program.wrench, commands)):
        if not np.all(np.isfinite(command)):
            continue
        try:
            target = robot.point_position(q + statics.solve(q, [])[0], tcp)
            theta = statics.solve(command, [Load(wrench[:3], tcp, wrench[3:])])[0]
        except SolverError:
            continue
        misses[p] = np.linalg.norm(robot.point_position(command + theta, tcp) - target)
    return misses


def independent_compensation_check(cell: Cell, plan: Plan, seed: int, *, poses: int = 100, repeats: int = 3, sampler: Sampler | None = None) -> pd.DataFrame:
    """A campaign of the independent generator (its own truth drawn about the cell's, its own tool, noise and
    statics), calibrated with the cell's model, and a random program compensated with it; the misses measured by
    the generator's statics (:func:`independent_misses`) against the predicted bounds.

    Returns
    -------
    pandas.DataFrame
        Per pose: ``miss_m``, ``q9973_m``, ``q9973_identified_m`` and ``inside`` (miss within the 99.73 % bound).
    """
    from bayescal.compensation.calibration import calibration_from_tree
    from bayescal.twin.independent.generator import IndependentGenerator

    rng = np.random.default_rng(seed)
    campaign, truth = IndependentGenerator(cell, rng).simulate(plan, repeats)
    options = {} if sampler is None else {"sampler": sampler}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, **options).fit(campaign, rng)
    program = random_program(cell, poses, rng)
    compensated = compensate_program(program, calibration_from_tree(results.tree, cell), cell)
    miss = independent_misses(cell, truth.world, program, compensated.commands)
    return pd.DataFrame(
        {
            "miss_m": miss,
            "q9973_m": compensated.errors["q9973"],
            "q9973_identified_m": compensated.budget.identified["q9973"],
            "inside": miss <= compensated.errors["q9973"],
        }
    )
