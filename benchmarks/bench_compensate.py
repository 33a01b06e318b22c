"""Time of ``compensate_program`` against the program's length, and against the per-pose, per-draw loop it replaces.

A Table III campaign is simulated on the twin and calibrated (default sampler);
random programs of 1,000 and 10,000 poses are compensated with the posterior's
uncertainty (wall and CPU time: cost should be linear in poses).  The naive
method solves, at every pose and for every posterior draw, the unloaded and
the loaded static equilibria of that draw's arm (:class:`ElasticArm`); it is
timed on a few poses and draws and scaled to the same draws, and the ratio printed.
Each program is also compensated, in the same run, by the previous code (:data:`PREVIOUS`: kinematics,
Jacobians and gravity torques one Pinocchio call per pose, loaded from the repository's history by
``previous.py``): both times, their ratio and the largest difference of the commands.
Sizes can be given as arguments: ``python benchmarks/bench_compensate.py 1000 10000``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from previous import NoHistory, previous
from smoke import SAMPLER, sized

ROOT = Path(__file__).resolve().parents[1]

PREVIOUS = "5b37cd4"
"""The commit whose ``bayescal/compensation`` is the baseline: the last before the poses were batched."""
NAIVE_POSES = sized(3, 1)
NAIVE_DRAWS = sized(100, 2)


def _naive_seconds_per_pose(cell, calibration, program) -> float:
    """Per-pose time of the loop over draws, scaled from :data:`NAIVE_DRAWS` to all the calibration's draws."""
    from bayescal.robot.compensator import Compensator
    from bayescal.robot.stiffness import ElasticArm

    began = time.process_time()
    for q, tcp, w in zip(program.q[:NAIVE_POSES], program.tcp, program.flange_wrench(np.stack([cell.robot.flange_pose(q)[0] for q in program.q[:NAIVE_POSES]]))):
        deflections = []
        for s in range(NAIVE_DRAWS):
            compensator = Compensator(*calibration.geometry[s], *calibration.spring[s])
            arm = ElasticArm.linear(cell.robot, calibration.own[s], compensator=compensator, compensated_joint=cell.compensated_joint)
            unloaded = cell.robot.point_position(q + arm.equilibrium(q, np.zeros(6)), tcp)
            deflections.append(cell.robot.point_position(q + arm.equilibrium(q, w), tcp) - unloaded)
        deflections = np.array(deflections)
        np.quantile(np.linalg.norm(deflections - deflections.mean(axis=0), axis=1), [0.95, 0.9973])
    return (time.process_time() - began) / NAIVE_POSES * calibration.n_draws / NAIVE_DRAWS


def main(sizes: list[int]) -> None:
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.compensation import compensate_program, load_calibration
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler
    from bayescal_studies.studies.compensation import random_program
    from bayescal.twin.simulator import DigitalTwin

    cell = load_cell(ROOT / "data" / "kr270.toml")
    campaign = DigitalTwin(cell).simulate(read_plan(ROOT / "data" / "table3_plan.csv", cell.robot), 3, np.random.default_rng(1))
    with warnings.catch_warnings(), tempfile.TemporaryDirectory() as folder:
        warnings.simplefilter("ignore")
        ElastostaticModel.from_cell(cell, sampler=elastostatic_sampler(**SAMPLER)).fit(campaign, 1).save(Path(folder) / "calibration.nc")
        calibration = load_calibration(Path(folder) / "calibration.nc", cell)
    try:
        before = previous("compensation", ("spread", "compensate"), PREVIOUS).compensate.compensate_program
    except NoHistory as reason:
        print(f"no baseline: {reason}")
        before = None
    fast = {}
    for n in sizes:
        program = random_program(cell, n, np.random.default_rng(n))
        wall, cpu = time.perf_counter(), time.process_time()
        commands = compensate_program(program, calibration, cell).commands
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        fast[n] = cpu / n
        print(f"{n:6d} poses x {calibration.n_draws} draws: {wall:6.2f} s wall {cpu:6.2f} s CPU  ({1e3 * cpu / n:.3f} ms CPU per pose)")
        if before is not None:
            old = time.process_time()
            previous_commands = before(program, calibration, cell).commands
            old = time.process_time() - old
            print(f"        previous code (a Pinocchio call per pose): {old:6.2f} s CPU, {old / cpu:4.2f}x the CPU; "
                  f"commands within {np.max(np.abs(commands - previous_commands)):.1e} rad")
    naive = _naive_seconds_per_pose(cell, calibration, random_program(cell, NAIVE_POSES, np.random.default_rng(0)))
    print(f"naive loop over poses and draws: {naive:.2f} s CPU per pose (timed on {NAIVE_POSES} poses x {NAIVE_DRAWS} draws, scaled)")
    for n, per_pose in fast.items():
        print(f"  ratio naive / compensate_program at {n} poses: {naive / per_pose:,.0f}")


if __name__ == "__main__":
    main([int(arg) for arg in sys.argv[1:]] or sized([1000, 10000], [10]))
