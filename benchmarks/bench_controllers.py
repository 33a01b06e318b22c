"""Time of compensating a controller program of Cartesian targets against a CSV of the same poses' joints.

A Table III campaign is simulated on the twin and calibrated (default sampler).  A
KRL program and a RAPID module of 10,000 Cartesian targets (random machining
configurations of the KR-270, in a base and a tool frame, with their status and
turn or ``confdata``) are read, solved for their joints, compensated under one
wrench and written; the CSV of the same joints is read, compensated and written
in the same run, and the ratio printed.  The size can be given as an argument:
``python benchmarks/bench_controllers.py 10000``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from smoke import SAMPLER, sized

ROOT = Path(__file__).resolve().parents[1]

WRENCH = (-800.0, 300.0, -500.0, 0.0, 20.0, 10.0)
"""The one process wrench of every target (N, N·m)."""


SHOULDER_CLEARANCE = 0.2
"""Least distance (m) of the wrist point from axis 1 in the programs."""


ELBOW_CLEARANCE = 0.02
"""Least distance (m) of the wrist point from the line through axes 2 and 3 in the programs."""


def _clearances(robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(N,)`` distances (m) of the wrist point (joint 5's origin) from axis 1 and from the line from axis 2 to axis 3."""
    from bayescal.robot.batched import BatchedChain

    poses = BatchedChain.of(robot).poses(q)
    wrist = poses.origins[:, 4]

    def off_line(start, direction):
        direction = direction / np.linalg.norm(direction, axis=1, keepdims=True)
        offset = wrist - start
        return np.linalg.norm(offset - np.einsum("ni,ni->n", offset, direction)[:, None] * direction, axis=1)

    return off_line(poses.origins[:, 0], poses.axes[:, 0]), off_line(poses.origins[:, 1], poses.origins[:, 2] - poses.origins[:, 1])


def _programs(cell, n: int, folder: Path) -> dict[str, Path]:
    """A CSV of ``n`` random configurations, and the KRL and RAPID programs of their tool poses."""
    from bayescal.controllers import configuration as conf
    from bayescal.controllers.poses import compose, inverse, kuka_angles, kuka_rotation, rotation_quaternion
    from bayescal.robot.batched import BatchedChain
    from bayescal_studies.studies.compensation import random_program

    program = random_program(cell, 2 * n, np.random.default_rng(n))
    # Poses whose wrist point is near axis 1 (the shoulder singularity) or on the line of the upper arm (the
    # stretched elbow) sit on the edge of status bit 0 or 1: a program written with 4 decimals may name either
    # side.  Machining programs stay clear of both; so does this one.
    shoulder, elbow = _clearances(cell.robot, program.q)
    keep = np.flatnonzero((shoulder > SHOULDER_CLEARANCE) & (elbow > ELBOW_CLEARANCE))[:n]
    q = program.q[keep]
    table = program.table.iloc[keep].copy()
    for j, value in enumerate(WRENCH):
        table[table.columns[6 + j]] = f"{value:g}"
    table.to_csv(folder / "program.csv", index=False)
    base = (kuka_rotation(np.array([[30.0, 0.0, 0.0]]))[0], np.array([1.5, -0.3, 0.2]))
    tool = (kuka_rotation(np.array([[0.0, -90.0, 0.0]]))[0], np.array([0.3, 0.0, 0.0]))
    flange = BatchedChain.of(cell.robot).poses(q)
    rotation, origin = compose(compose(inverse(base), (flange.flange_rotation, flange.flange_origin)), tool)
    xyz, abc, quaternion = origin * 1000.0, kuka_angles(rotation), rotation_quaternion(rotation)
    status, turn = conf.kuka_status(cell.robot, q), conf.kuka_turn(q)
    cfx, quadrants = conf.abb_cfx(cell.robot, q), conf.abb_quadrants(q)
    dat = ["DEFDAT mill", "DECL FRAME TABLE={X 1500,Y -300,Z 200,A 30,B 0,C 0}", "DECL FRAME SPINDLE={X 300,Y 0,Z 0,A 0,B -90,C 0}"]
    src = ["DEF mill( )", "$TOOL = SPINDLE", "$BASE = TABLE"]
    mod = ["MODULE Mill", "    PERS tooldata spindle:=[TRUE,[[300,0,0],[0.707106781,0,-0.707106781,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];",
           '    TASK PERS wobjdata table:=[FALSE,TRUE,"",[[1500,-300,200],[0.965925826,0,0,0.258819045]],[[0,0,0],[1,0,0,0]]];']
    moves = []
    for i in range(n):
        x, y, z = xyz[i]
        a, b, c = abc[i]
        dat.append(f"DECL E6POS XP{i}={{X {x:.4f},Y {y:.4f},Z {z:.4f},A {a:.4f},B {b:.4f},C {c:.4f},S {status[i]},T {turn[i]},E1 0.0}}")
        src.append(f"{('PTP', 'LIN')[i % 2]} XP{i}")
        w, qx, qy, qz = quaternion[i]
        mod.append(f"    CONST robtarget P{i}:=[[{x:.4f},{y:.4f},{z:.4f}],[{w:.6f},{qx:.6f},{qy:.6f},{qz:.6f}],"
                   f"[{quadrants[i, 0]},{quadrants[i, 1]},{quadrants[i, 2]},{cfx[i]}],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];")
        moves.append(f"        {('MoveJ', 'MoveL')[i % 2]} P{i},v200,z1,spindle\\WObj:=table;")
    (folder / "mill.src").write_text("\n".join(src + ["END"]) + "\n")
    (folder / "mill.dat").write_text("\n".join(dat + ["ENDDAT"]) + "\n")
    (folder / "mill.mod").write_text("\n".join(mod + ["    PROC main()"] + moves + ["    ENDPROC", "ENDMODULE"]) + "\n")
    return {"CSV": folder / "program.csv", "KRL": folder / "mill.src", "RAPID": folder / "mill.mod"}


def main(n: int) -> None:
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.compensation import compensate_program, load_calibration, read_program
    from bayescal.controllers.compensate import (
        compensate_controller_program, constant_wrench, output_paths, program_joints, read_controller_program,
    )
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler
    from bayescal.twin.simulator import DigitalTwin

    cell = load_cell(ROOT / "data" / "kr270.toml")
    campaign = DigitalTwin(cell).simulate(read_plan(ROOT / "data" / "table3_plan.csv", cell.robot), 3, np.random.default_rng(1))
    with warnings.catch_warnings(), tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        warnings.simplefilter("ignore")
        ElastostaticModel.from_cell(cell, sampler=elastostatic_sampler(**SAMPLER)).fit(campaign, 1).save(folder / "calibration.nc")
        calibration = load_calibration(folder / "calibration.nc", cell)
        paths = _programs(cell, n, folder)
        seconds = {}
        began = time.perf_counter()
        compensate_program(read_program(paths["CSV"], cell), calibration, cell).save(folder / "out.csv")
        seconds["CSV"] = time.perf_counter() - began
        for language in ("KRL", "RAPID"):
            began = time.perf_counter()
            program = read_controller_program(paths[language])
            read = time.perf_counter()
            compensated = compensate_controller_program(program, constant_wrench(WRENCH, program, cell), calibration, cell)
            outputs = output_paths(folder / f"out{paths[language].suffix}", program)
            for role, text in compensated.texts().items():
                outputs[role].write_bytes(text.encode("latin-1"))
            seconds[language] = time.perf_counter() - began
            solving = time.perf_counter()
            program_joints(program, cell.robot)
            solving = time.perf_counter() - solving
            print(f"{language:5s} {n} Cartesian targets read, solved, compensated and written: {seconds[language]:6.2f} s "
                  f"(reading {read - began:.2f} s; solving alone, timed again after: {solving:.2f} s)")
        print(f"CSV   {n} joint rows read, compensated and written:                  {seconds['CSV']:6.2f} s")
        for language in ("KRL", "RAPID"):
            print(f"  ratio {language} / CSV: {seconds[language] / seconds['CSV']:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else sized(10000, 20))
