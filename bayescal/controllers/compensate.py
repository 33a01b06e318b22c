"""Compensation of a controller program: targets → joints → compensated joints → the targets to command.

Joint targets are compensated as they are.  A Cartesian target is first solved
for the joints that put the program's tool at it in the program's base frame,
in the configuration its status and turn (KRL) or ``confdata`` (RAPID) name, with
the controller's own model: the cell's URDF (:mod:`bayescal.robot.inverse`).  Those
joints are the programmed joints of :func:`~bayescal.compensation.compensate.compensate_program`;
its compensated joints are turned back into the pose that the same nominal model
puts the tool at, which is what the controller must be commanded to so that the
loaded arm lands on the target.  The configuration written is the compensated
joints' (the same as the target's except where an axis crosses zero, which
changes a turn bit and nothing else).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, replace
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.cell.campaign_checks import check_wrench
from bayescal.cell.config import Cell
from bayescal.cell.joint_tables import RADIAN_SPAN, JointLayout
from bayescal.compensation.calibration import Calibration
from bayescal.compensation.compensate import compensate_program
from bayescal.compensation.program import Program
from bayescal.compensation.results import DECIMALS, FLAG_OK, CompensationResults
from bayescal.controllers import configuration as conf
from bayescal.controllers.krl import read_krl, status_text, write_krl
from bayescal.controllers.poses import compose, inverse, kuka_angles, rotation_quaternion
from bayescal.controllers.program import ControllerProgram, Rewrite
from bayescal.controllers.rapid import read_rapid, write_rapid
from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.batched import BatchedChain
from bayescal.robot.inverse import POSITION_TOLERANCE, inverse_kinematics
from bayescal.robot.kinematics import Robot
from bayescal.summary import Paragraph, Summary
from bayescal.units import DEG, MM

__all__ = [
    "CONTROLLER_SUFFIXES", "read_controller_program", "read_wrenches", "program_joints", "ControllerCompensation",
    "compensate_controller_program", "output_paths", "constant_wrench",
]

CONTROLLER_SUFFIXES = {".src": "KRL", ".mod": "RAPID"}
"""File suffixes (any case) of the controller programs read, and their language."""

WRENCH_FILE_COLUMNS = ("target", "fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm")
"""The columns of a wrench file: one row per target name."""


def read_controller_program(path: str | PathLike[str]) -> ControllerProgram:
    """Read a KRL ``.src`` (with its ``.dat``) or a RAPID ``.mod``, by the file's suffix."""
    language = CONTROLLER_SUFFIXES.get(Path(path).suffix.lower())
    if language is None:
        raise InputError(f"expected a program ending in {', '.join(CONTROLLER_SUFFIXES)} or .csv", source=str(path))
    return read_krl(path) if language == "KRL" else read_rapid(path)


def output_paths(path: str | PathLike[str], program: ControllerProgram) -> dict[str, Path]:
    """Where each of the program's files is written for the output ``path``: ``OUT.src`` and ``OUT.dat``, or ``OUT.mod``."""
    out = Path(path)
    if out.suffix.lower() != Path(program.source).suffix.lower():
        raise InputError(f"the compensated program is written in the language it came in: name a {Path(program.source).suffix} file", source="output")
    if program.language == "KRL":
        return {"src": out, "dat": out.with_suffix(".dat" if out.suffix.islower() else ".DAT")}
    return {"mod": out}


def read_wrenches(path: str | PathLike[str], program: ControllerProgram, cell: Cell) -> np.ndarray:
    """``(P, 6)`` the wrench of each of ``program``'s targets (N, N·m) from a file of :data:`WRENCH_FILE_COLUMNS`,
    checked as a program's process wrenches (:func:`~bayescal.cell.campaign_checks.check_wrench`).

    Raises
    ------
    InputError
        A missing column, a bad number, a target named twice, a target the program does not
        move to, or a target of the program without a row.
    """
    file = Path(path)
    source = str(path)
    if not file.is_file():
        raise InputError("wrench file not found", source=source)
    record_read(file, "the wrench file")
    with open(file, encoding="utf-8-sig", newline="") as handle:
        rows = [(number, row) for number, row in enumerate(csv.reader(handle, skipinitialspace=True), start=1) if row and not row[0].lstrip().startswith("#")]
    if not rows:
        raise InputError(f"empty file; expected the columns {', '.join(WRENCH_FILE_COLUMNS)}", source=source)
    header_line, header = rows[0]
    header = [name.strip() for name in header]
    for name in WRENCH_FILE_COLUMNS:
        if name not in header:
            raise InputError(f"missing column '{name}' (expected {', '.join(WRENCH_FILE_COLUMNS)})", source=source, line=header_line, column=name)
    position = {name: header.index(name) for name in WRENCH_FILE_COLUMNS}
    names = {target.name.upper(): i for i, target in enumerate(program.targets)}
    wrench = np.full((len(program.targets), 6), np.nan)
    lines = np.zeros(len(program.targets), dtype=int)
    for number, row in rows[1:]:
        if len(row) != len(header):
            raise InputError(f"expected {len(header)} fields, got {len(row)}", source=source, line=number)
        name = row[position["target"]].strip()
        if name.upper() not in names:
            raise InputError(f"target '{name}' is not moved to by {Path(program.source).name}", source=source, line=number, column="target")
        i = names[name.upper()]
        if lines[i]:
            raise InputError(f"target '{name}' is given twice (first at line {lines[i]})", source=source, line=number, column="target")
        for k, column in enumerate(WRENCH_FILE_COLUMNS[1:]):
            text = row[position[column]].strip()
            try:
                wrench[i, k] = float(text)
            except ValueError:
                raise InputError(f"expected a number, got '{text}'", source=source, line=number, column=column) from None
            if not np.isfinite(wrench[i, k]):
                raise InputError(f"expected a finite number, got '{text}'", source=source, line=number, column=column)
        lines[i] = number
    missing = [target.name for target, line in zip(program.targets, lines) if not line]
    if missing:
        raise InputError(f"no wrench for target{'s' if len(missing) > 1 else ''} {', '.join(missing[:5])}{' …' if len(missing) > 5 else ''}", source=source, column="target")
    check_wrench(cell, wrench, lines, source, what="process", about="the tool point", smallest=False)
    return wrench


def constant_wrench(values, program: ControllerProgram, cell: Cell, *, source: str = "wrench") -> np.ndarray:
    """``(P, 6)`` one wrench ``[fx, fy, fz, mx, my, mz]`` (N, N·m) for every target, checked as a process wrench;
    errors name ``source`` (the library's argument; the CLI maps it to its flag)."""
    wrench = np.asarray(values, dtype=float).reshape(1, 6)
    try:
        check_wrench(cell, wrench, [1], source, what="process", about="the tool point", smallest=False)
    except InputError as error:
        raise InputError(error.what, source=source, column=error.column) from None
    return np.repeat(wrench, len(program.targets), axis=0)


def _flange_targets(program: ControllerProgram, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(K, 3, 3)``, ``(K, 3)`` the flange poses (robot base frame, m) at which the tool is at the Cartesian targets ``rows``."""
    targets = [program.targets[i] for i in rows]
    base = (np.array([t.base[0] for t in targets]), np.array([t.base[1] for t in targets]))
    pose = (np.array([t.rotation for t in targets]), np.array([t.origin for t in targets]))
    tool = (np.array([t.tool[0] for t in targets]), np.array([t.tool[1] for t in targets]))
    return compose(compose(base, pose), inverse(tool))


def _rules(program: ControllerProgram, robot: Robot, rows: np.ndarray):
    """The wanted classes ``(K,)``, the classifier, whether an angle is on its named side, and how to name a configuration."""
    targets = [program.targets[i] for i in rows]
    if program.language == "KRL":
        turn = np.array([t.configuration["T"] for t in targets])

        def side(angle: np.ndarray, j: int) -> np.ndarray:
            return (angle < 0) == (((turn >> j) & 1) == 1)

        def classify(q: np.ndarray) -> np.ndarray:
            return conf.kuka_status(robot, q)

        return np.array([t.configuration["S"] & 7 for t in targets]), classify, side, lambda value: f"S {value}"
    named = {j: np.array([t.configuration[key] for t in targets]) for j, key in {0: "cf1", 3: "cf4", 5: "cf6"}.items()}

    def side(angle: np.ndarray, j: int) -> np.ndarray:
        return np.floor(angle / (np.pi / 2)) == named[j] if j in named else np.ones(len(angle), dtype=bool)

    def classify(q: np.ndarray) -> np.ndarray:
        return conf.abb_cfx(robot, q)

    return np.array([t.configuration["cfx"] for t in targets]), classify, side, lambda value: f"cfx {value}"


def program_joints(program: ControllerProgram, robot: Robot) -> np.ndarray:
    """``(P, 6)`` the programmed joints (rad) of every target: joint targets as written, Cartesian ones solved.

    Raises
    ------
    InputError
        Naming the target's declaration: joints outside their limits or written in radians, a pose out of reach,
        or one the named configuration does not reach (the arm would flip).
    """
    conf.check_six_axis(robot, program.source)
    q = np.array([t.q for t in program.targets]).reshape(-1, robot.nq)
    joint_rows = np.flatnonzero([not t.cartesian for t in program.targets])
    _check_radians(program, robot, joint_rows)
    rows = np.flatnonzero([t.cartesian for t in program.targets])
    if rows.size:
        rotation, origin = _flange_targets(program, rows)
        wanted, classify, side, name = _rules(program, robot, rows)
        solution = inverse_kinematics(robot, rotation, origin, wanted, classify)
        for k in np.flatnonzero(~solution.kept):
            target = program.targets[rows[k]]
            if not solution.reached[k]:
                why = f"no joints put the tool within {POSITION_TOLERANCE / MM:g} mm of it: the pose is out of the robot's reach"
            else:
                why = f"{name(wanted[k])} does not reach it, {name(solution.found[k])} does: the arm would flip; check the target's configuration"
            raise InputError(f"target {target.name}: {why}", source=target.source, line=target.line)
        solved = conf.turned_to(robot, solution.q, side)
        for j in range(robot.nq):
            wrong = np.flatnonzero(~side(solved[:, j], j))
            if wrong.size:
                target = program.targets[rows[wrong[0]]]
                raise InputError(
                    f"target {target.name}: axis {j + 1} at {solved[wrong[0], j] / DEG:.2f} deg cannot be turned to the side its "
                    f"{'turn T' if program.language == 'KRL' else 'confdata'} names within its limits: the arm would flip",
                    source=target.source, line=target.line,
                )
        q[rows] = solved
    for i, target in enumerate(program.targets):
        robot.check_limits(q[i], source=target.source, line=target.line)
    return q


def _check_radians(program: ControllerProgram, robot: Robot, rows: np.ndarray) -> None:
    """Refuse joint targets written in radians: two or more, every angle within the layout's radian bound."""
    if rows.size < 2:
        return
    angles = np.array([program.targets[i].q for i in rows]) / DEG
    if len(np.unique(angles, axis=0)) >= 2 and np.all(np.abs(angles) <= JointLayout.of(robot).radian_bound):
        first = program.targets[rows[0]]
        raise InputError(
            f"every axis angle of the {rows.size} joint targets lies within ±{RADIAN_SPAN:g} deg, as angles in radians would: "
            "the controller's axis values are in degrees",
            source=first.source, line=first.line, column="A1" if program.language == "KRL" else "rax_1",
        )


@dataclass
class ControllerCompensation:
    """A compensated controller program.

    Attributes
    ----------
    program : ControllerProgram
    results : CompensationResults
        The compensation of the targets' joints (``results.program.q`` the programmed joints).
    """

    program: ControllerProgram
    results: CompensationResults

    def rewrites(self) -> dict:
        """:class:`~bayescal.controllers.program.Rewrite` of every target, in the language's units."""
        robot = self.results.robot
        commands = self.results.commands
        bad = np.flatnonzero(~np.all(np.isfinite(commands), axis=1))
        if bad.size:
            target = self.program.targets[bad[0]]
            raise InputError(f"target {target.name}: the arm has no static equilibrium under its wrench; nothing is written",
                             source=target.source, line=target.line)
        rows = np.flatnonzero([t.cartesian for t in self.program.targets])
        poses = {}
        if rows.size:
            chain = BatchedChain.of(robot)
            flange = chain.poses(commands[rows])
            targets = [self.program.targets[i] for i in rows]
            base = (np.array([t.base[0] for t in targets]), np.array([t.base[1] for t in targets]))
            tool = (np.array([t.tool[0] for t in targets]), np.array([t.tool[1] for t in targets]))
            rotation, origin = compose(compose(inverse(base), (flange.flange_rotation, flange.flange_origin)), tool)
            poses = {i: k for k, i in enumerate(rows)}
            if self.program.language == "KRL":
                angles = kuka_angles(rotation)
                status = conf.kuka_status(robot, commands[rows])
                turn = conf.kuka_turn(commands[rows])
            else:
                quaternion = rotation_quaternion(rotation)
                # The same rotation, kept in the hemisphere the file wrote each quaternion in.
                quaternion *= np.where(np.einsum("ni,ni->n", quaternion, np.array([t.orientation for t in targets])) < 0, -1.0, 1.0)[:, None]
                cfx = conf.abb_cfx(robot, commands[rows])
                quadrants = conf.abb_quadrants(commands[rows])
        bounds = self.results.errors["q9973"]
        flags = self.results.flags
        out = {}
        for i, target in enumerate(self.program.targets):
            comment = f"bayescal: compensated, 99.73 % error bound {bounds[i] / MM:.4f} mm" + ("" if flags[i] == FLAG_OK else f"; {flags[i]}")
            if not target.cartesian:
                keys = ("A1", "A2", "A3", "A4", "A5", "A6") if self.program.language == "KRL" else tuple(f"rax_{j + 1}" for j in range(6))
                out[target.name] = Rewrite(dict(zip(keys, commands[i] / DEG)), comment)
                continue
            k = poses[i]
            if self.program.language == "KRL":
                fields = self.program.spans[target.name][2]
                values = dict(zip(("X", "Y", "Z"), origin[k] / MM)) | dict(zip(("A", "B", "C"), angles[k]))
                values["S"] = status_text(fields["S"][2], (target.configuration["S"] & ~7) | int(status[k]))
                values["T"] = status_text(fields["T"][2], (target.configuration["T"] & ~63) | int(turn[k]))
            else:
                values = dict(zip(("x", "y", "z"), origin[k] / MM)) | dict(zip(("q1", "q2", "q3", "q4"), quaternion[k]))
                values |= {"cf1": quadrants[k, 0], "cf4": quadrants[k, 1], "cf6": quadrants[k, 2], "cfx": cfx[k]}
            out[target.name] = Rewrite(values, comment)
        return out

    def texts(self, decimals: int = DECIMALS) -> dict[str, str]:
        """Each of the program's files (by role) as the compensated program writes it."""
        writer = write_krl if self.program.language == "KRL" else write_rapid
        return writer(self.program, self.rewrites(), decimals)

    def summary_json(self) -> dict:
        """The program's counts: language, targets (Cartesian, joint), motions, statements passed through."""
        cartesian = sum(t.cartesian for t in self.program.targets)
        return {
            "language": self.program.language,
            "targets": len(self.program.targets),
            "cartesian_targets": cartesian,
            "joint_targets": len(self.program.targets) - cartesian,
            "motions": self.program.motions,
            "unsupported_statements_passed_through": self.program.unsupported,
        }

    def document(self) -> Summary:
        """The compensation's document (:meth:`CompensationResults.document`) and the program's counts after it."""
        s = self.summary_json()
        document = self.results.document()
        counts = Paragraph(f"{s['language']}: {s['targets']} targets ({s['cartesian_targets']} Cartesian, {s['joint_targets']} joint) of "
                           f"{s['motions']} motions; {s['unsupported_statements_passed_through']} unsupported statements passed through unchanged")
        return replace(document, lead=document.lead + (counts,))

    def to_json(self) -> dict:
        """The compensation's JSON with the program's counts under ``program``."""
        return self.results.to_json() | {"program": self.summary_json()}


def compensate_controller_program(
    program: ControllerProgram, wrench: np.ndarray, calibration: Calibration, cell: Cell, *, tolerance: float | None = None
) -> ControllerCompensation:
    """Compensate every target of ``program`` under its ``(P, 6)`` wrench (N, N·m, robot base axes, about the tool point:
    :func:`read_wrenches`, :func:`constant_wrench`).

    The tool point of each target is its motion's tool origin in the flange frame.
    """
    q = program_joints(program, cell.robot)
    tcp = np.array([t.tool[1] for t in program.targets]).reshape(-1, 3)
    lines = np.array([t.line for t in program.targets], dtype=int)
    source = program.source
    table = pd.DataFrame({"target": [t.name for t in program.targets], "file": [Path(t.source).name for t in program.targets]}, index=lines)
    results = compensate_program(Program(q=q, wrench=np.asarray(wrench, dtype=float), tcp=tcp, table=table, source=source), calibration, cell, tolerance=tolerance)
    return ControllerCompensation(program=program, results=results)
