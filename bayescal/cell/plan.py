"""Calibration plans: the robot configurations of an elastostatic campaign and their loads.

A plan CSV has one row per configuration with the controller's joint angles
``q1_deg`` … ``q<n>_deg`` (``q<j>_mm``, in mm, for a prismatic joint) and, optionally, its
load: either the mass ``load_kg`` hung at the tool's load point, or a force
``fx_N, fy_N, fz_N`` (base axes) applied through the load point by an end-effector
that can push or pull in any direction (:mod:`bayescal.cell.loading`); either may
come with a couple ``mx_Nm, my_Nm, mz_Nm`` (base axes).  Configurations are
numbered 1, 2, … in file order; lines starting with ``#`` are provenance notes.

An optional column :data:`PASSES_COLUMN` (``in_passes``, 1 on every line) says that the plan is
measured whole once per repeat, in passes, rather than each configuration's repeats one after
another: a configuration's repeats then lie a pass apart in time, so that its readings of one
state show the tracker's drift (:mod:`bayescal.registration.repeats`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.cell.joint_tables import JointLayout, read_joint_columns
from bayescal.cell.loading import Loading
from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot
from bayescal.tables import read_header
from bayescal.units import DEG, MM

__all__ = ["FORCE_COLUMNS", "COUPLE_COLUMNS", "Plan", "position_columns", "prismatic_flags", "read_plan", "write_plan",
           "PASSES_COLUMN", "passes_column", "read_passes"]

PASSES_COLUMN = "in_passes"
"""A plan's column saying, 1 on every line, that the plan is measured once per pass; plan readers ignore it."""

FORCE_COLUMNS = ("fx_N", "fy_N", "fz_N")
"""A plan's force columns: the force through the load point, base axes, N."""

COUPLE_COLUMNS = ("mx_Nm", "my_Nm", "mz_Nm")
"""A plan's couple columns: a pure couple on the tool, base axes, N·m."""

_STANDARD_GRAVITY = 9.80665
"""m/s²: turns ``max_load_kg`` into the largest plausible force of a force column."""


@dataclass(frozen=True, eq=False)
class Plan:
    """Measurement configurations, SI.

    Attributes
    ----------
    q : numpy.ndarray
        (M, nq) joint positions, rad (m for a prismatic joint).
    load_kg : numpy.ndarray or None
        (M,) load masses, kg; ``None`` when the plan leaves them to the cell.
    lines : numpy.ndarray
        (M,) line numbers in the source file.
    source : str
    force : numpy.ndarray or None
        (M, 3) forces through the load point, base axes, N; when given, ``load_kg`` is ``None``.
    couple : numpy.ndarray or None
        (M, 3) couples, base axes, N·m.
    prismatic : numpy.ndarray of bool or None
        (nq,) which joints are prismatic (written in mm); ``None``: all revolute.
    """

    q: np.ndarray
    load_kg: np.ndarray | None
    lines: np.ndarray
    source: str = "<memory>"
    force: np.ndarray | None = None
    couple: np.ndarray | None = None
    prismatic: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q)

    def masses(self, default: float) -> np.ndarray:
        """(M,) the load of each configuration, kg: the plan's own, or ``default`` everywhere."""
        return np.full(len(self), float(default)) if self.load_kg is None else self.load_kg.copy()

    def forces(self, default_mass: float, gravity: float) -> np.ndarray:
        """(M, 3) the force through the load point of each configuration, base axes, N.

        The plan's own forces, else the weight of its masses (``default_mass`` kg where it has none).
        """
        if self.force is not None:
            return self.force.copy()
        weight = np.zeros((len(self), 3))
        weight[:, 2] = -self.masses(default_mass) * gravity
        return weight

    def couples(self) -> np.ndarray:
        """(M, 3) the couple of each configuration, base axes, N·m (zero where the plan has none)."""
        return np.zeros((len(self), 3)) if self.couple is None else self.couple.copy()

    def wrenches(self, cell) -> np.ndarray:
        """(M, 6) each configuration's load as a wrench at the flange origin, base axes (``cell.wrench``)."""
        forces = self.forces(cell.load_mass, cell.gravity)
        couples = self.couples()
        return np.array([cell.wrench(q, f, c) for q, f, c in zip(self.q, forces, couples)])

    def describe_load(self, row: int, default_mass: float) -> str:
        """Row ``row``'s load in words, for error messages."""
        if self.force is None:
            text = f"{self.masses(default_mass)[row]:g} kg"
        else:
            text = "a force of [" + ", ".join(f"{v:.1f}" for v in self.force[row]) + "] N"
        if self.couple is not None and np.any(self.couple[row]):
            text += " and a couple of [" + ", ".join(f"{v:.1f}" for v in self.couple[row]) + "] N m"
        return text


def read_plan(
    path: str | PathLike[str], robot: Robot, *, max_load_kg: float | None = None, loading: Loading | None = None
) -> Plan:
    """Read a plan CSV for ``robot``, checking every row against the joint limits.

    Parameters
    ----------
    path
        The plan CSV.
    robot
        The robot whose joints and limits the plan must match.
    max_load_kg
        The heaviest plausible load, kg (e.g. ``cell.max_force / cell.gravity``);
        a heavier ``load_kg``, or a larger force (as a weight), is an error.
    loading
        What the cell's end-effector can apply (``cell.loading``); a force or couple
        it cannot apply is an error.  ``None``: any force and couple.

    Raises
    ------
    InputError
        Naming the line and column of a missing column, a joint column the robot
        does not have, a value that is not a number, a joint angle outside its
        limits or written in radians (the checks of every joint-angle table,
        :mod:`bayescal.cell.joint_tables`), a load that is not positive or above ``max_load_kg``, force or
        couple columns given in part or a force given with ``load_kg``, or a load
        the end-effector cannot apply.
    """
    source = str(path)
    _check_load_columns(read_header(path), source)
    lines, values, q = read_joint_columns(
        path,
        JointLayout.of(robot),
        {},
        what="plan",
        optional={"load_kg": "number"} | {name: "number" for name in FORCE_COLUMNS + COUPLE_COLUMNS},
        units={"load_kg": "kg"} | dict.fromkeys(FORCE_COLUMNS, "N") | dict.fromkeys(COUPLE_COLUMNS, "N·m"),
    )
    load = _masses(lines, values["load_kg"], max_load_kg, source) if "load_kg" in values else None
    # (N, 3), each column a run of memory, as a frame's columns give it
    force = np.array([values[name] for name in FORCE_COLUMNS], dtype=float).T if FORCE_COLUMNS[0] in values else None
    couple = np.array([values[name] for name in COUPLE_COLUMNS], dtype=float).T if COUPLE_COLUMNS[0] in values else None
    _check_wrenches(lines.tolist(), force, couple, max_load_kg, loading, source)
    return Plan(q=q, load_kg=load, lines=lines, source=source, force=force, couple=couple, prismatic=prismatic_flags(robot))


def _masses(lines: np.ndarray, masses: list[float], max_load_kg: float | None, source: str) -> np.ndarray:
    """The plan's ``load_kg`` column (``masses`` on ``lines``), kg, each positive and at most ``max_load_kg``."""
    load = np.array(masses, dtype=float)
    bad = np.flatnonzero(load <= 0)
    if len(bad):
        raise InputError(f"expected a positive mass in kg, got {masses[bad[0]]:g}", source=source, line=int(lines[bad[0]]), column="load_kg")
    if max_load_kg is not None and np.any(load > max_load_kg):
        row = int(np.argmax(load > max_load_kg))
        raise InputError(
            f"a load of {load[row]:g} kg is more than the {max_load_kg:.0f} kg the arm can plausibly carry: "
            "is load_kg in another unit than kg?",
            source=source,
            line=int(lines[row]),
            column="load_kg",
        )
    return load


def _check_load_columns(header: tuple[int, list[str]] | None, source: str) -> None:
    """Force and couple columns come in threes, and a force replaces ``load_kg``."""
    if header is None:
        return  # read_table names the problem
    line, names = header
    for group in (FORCE_COLUMNS, COUPLE_COLUMNS):
        present = [name for name in group if name in names]
        if present and len(present) < 3:
            missing = [name for name in group if name not in names][0]
            raise InputError(f"missing column {missing}: expected all of {', '.join(group)} or none", source=source, line=line, column=missing)
    if FORCE_COLUMNS[0] in names and "load_kg" in names:
        raise InputError(
            "expected either load_kg (a hanging mass) or fx_N, fy_N, fz_N (a force), not both", source=source, line=line, column="load_kg"
        )


def _check_wrenches(lines, force, couple, max_load_kg, loading: Loading | None, source: str) -> None:
    """Forces the arm can carry and the end-effector can apply, couples it can apply."""
    for row, line in enumerate(lines):
        reason, column = None, None
        if force is not None:
            size = float(np.linalg.norm(force[row]))
            if max_load_kg is not None and size > max_load_kg * _STANDARD_GRAVITY:
                reason = (
                    f"a force of {size:.4g} N is more than the weight of the {max_load_kg:.0f} kg the arm can plausibly carry: "
                    "are fx_N..fz_N in another unit than N?"
                )
            elif loading is not None:
                reason = loading.force_violation(force[row])
            column = FORCE_COLUMNS[int(np.argmax(np.abs(force[row])))]
        if reason is None and couple is not None and loading is not None:
            reason = loading.couple_violation(couple[row])
            column = COUPLE_COLUMNS[int(np.argmax(np.abs(couple[row])))]
        if reason is not None:
            raise InputError(reason, source=source, line=int(line), column=column)


def prismatic_flags(robot: Robot) -> np.ndarray | None:
    """A plan's or a campaign's ``prismatic`` field for ``robot``: a copy of its flags, ``None`` for an all-revolute arm."""
    return robot.prismatic.copy() if robot.prismatic.any() else None


def position_columns(n: int, prismatic: np.ndarray | None) -> tuple[list[str], np.ndarray]:
    """The plan and campaign files' column of each of ``n`` joints and the SI value of its unit.

    ``q<j>_deg`` (rad per deg) for a revolute joint, ``q<j>_mm`` (m per mm) for a joint that
    ``prismatic`` (``(n,)`` bool, or ``None`` for an all-revolute arm) flags; as
    :attr:`~bayescal.robot.kinematics.Robot.position_columns` names them for a robot.
    """
    flags = np.zeros(n, dtype=bool) if prismatic is None else np.asarray(prismatic, dtype=bool)
    return [f"q{j + 1}_{'mm' if linear else 'deg'}" for j, linear in enumerate(flags)], np.where(flags, MM, DEG)


def write_plan(plan: Plan, path: str | PathLike[str], *, comments: Sequence[str] = (), extra: Mapping[str, Sequence[int]] | None = None) -> None:
    """Write ``plan`` in the format :func:`read_plan` reads; ``comments`` become leading ``#`` lines, ``extra``
    integer columns (one value per configuration) follow the plan's own.

    Joint angles are written with 3 decimals in deg (about 17 μrad, far below the
    controllers' repeatability), prismatic joints' positions with 3 decimals in mm,
    loads with 1 decimal in kg, forces in N and couples in N·m.
    """
    lines = [f"# {line}" for comment in comments for line in str(comment).splitlines()]
    joints, scale = position_columns(plan.q.shape[1], plan.prismatic)
    columns = joints + ([] if plan.load_kg is None else ["load_kg"])
    columns += list(FORCE_COLUMNS) * (plan.force is not None) + list(COUPLE_COLUMNS) * (plan.couple is not None)
    extra = dict(extra or {})
    lines.append(",".join(columns + list(extra)))
    for number, q in enumerate(plan.q):
        fields = [_decimal(value / unit, 3) for value, unit in zip(q, scale)]
        if plan.load_kg is not None:
            fields.append(f"{float(plan.load_kg[number]):.1f}")
        for values in (plan.force, plan.couple):
            if values is not None:
                fields += [_decimal(value, 1) for value in values[number]]
        lines.append(",".join(fields + [str(int(values[number])) for values in extra.values()]))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def _decimal(value: float, places: int) -> str:
    # "+ 0.0" turns a rounded -0.0 into 0.0 so the file does not depend on rounding sign.
    return f"{round(float(value), places) + 0.0:.{places}f}"


def passes_column(n_configurations: int, repeats: int) -> tuple[str, np.ndarray]:
    """The plan's :data:`PASSES_COLUMN` ``(n_configurations,)`` of ones, and the note that says how to measure it."""
    note = (f"{PASSES_COLUMN} = 1: measure the plan whole, in this order, once per pass, {repeats} passes (each pass one repeat "
            "of every configuration): a configuration's repeats then lie a pass apart in time, and with the readings' "
            "times (t0_s, t1_s) they measure the tracker's drift (calibrate --drift-from-repeats)")
    return note, np.ones(n_configurations, dtype=int)


def read_passes(path: str | PathLike[str]) -> bool:
    """Whether the plan CSV at ``path`` is measured in passes (:data:`PASSES_COLUMN`; False without the column).

    Raises
    ------
    InputError
        A value other than 0 or 1, or one that differs from the first line's, naming its line.
    """
    from bayescal.tables import read_table

    header = read_header(path)
    if header is None or PASSES_COLUMN not in header[1]:
        return False
    frame = read_table(path, {PASSES_COLUMN: "integer"})
    values = frame[PASSES_COLUMN].to_numpy(dtype=int)
    wrong = np.flatnonzero((values != values[0]) | ((values != 0) & (values != 1)))
    if wrong.size:
        raise InputError(f"expected {values[0] if values[0] in (0, 1) else 1} on every line (the plan is measured in passes "
                         f"or not), got {values[wrong[0]]}", source=str(path), line=int(frame.index[wrong[0]]), column=PASSES_COLUMN)
    return bool(values[0])
