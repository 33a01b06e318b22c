"""Calibration plans: the robot configurations of an elastostatic campaign and their loads.

A plan CSV has one row per configuration with the controller's joint angles
``q1_deg`` … ``q<n>_deg`` (``q<j>_mm``, in mm, for a prismatic joint) and, optionally, the mass ``load_kg`` hung at the tool's
load point in that configuration.  Configurations are numbered 1, 2, … in file
order; lines starting with ``#`` are provenance notes.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot
from bayescal.tables import read_header, read_table
from bayescal.units import DEG, MM

__all__ = ["Plan", "read_plan", "write_plan"]


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
    prismatic : numpy.ndarray of bool or None
        (nq,) which joints are prismatic (written in mm); ``None``: all revolute.
    """

    q: np.ndarray
    load_kg: np.ndarray | None
    lines: np.ndarray
    source: str = "<memory>"
    prismatic: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q)

    def masses(self, default: float) -> np.ndarray:
        """(M,) the load of each configuration, kg: the plan's own, or ``default`` everywhere."""
        return np.full(len(self), float(default)) if self.load_kg is None else self.load_kg.copy()


def read_plan(path: str | PathLike[str], robot: Robot, *, max_load_kg: float | None = None) -> Plan:
    """Read a plan CSV for ``robot``, checking every row against the joint limits.

    Parameters
    ----------
    path
        The plan CSV.
    robot
        The robot whose joints and limits the plan must match.
    max_load_kg
        The heaviest plausible load, kg (e.g. ``cell.max_force / cell.gravity``);
        a heavier ``load_kg`` is an error.

    Raises
    ------
    InputError
        Naming the line and column of a missing column, a joint column the robot
        does not have, a value that is not a number, a joint angle outside its
        limits, or a load that is not positive or above ``max_load_kg``.
    """
    source = str(path)
    joints = list(robot.position_columns)
    header = read_header(path)
    extra = [name for name in (header[1] if header else []) if re.fullmatch(r"q[0-9]+_(deg|mm)", name) and name not in joints]
    if extra:
        raise InputError(
            f"the plan has a column {extra[0]} but the robot ({robot.source}) has {robot.nq} joints: "
            f"expected the columns {joints[0]}..{joints[-1]}",
            source=source,
            line=header[0],
            column=extra[0],
        )
    frame = read_table(
        path,
        {name: "number" for name in joints},
        optional={"load_kg": "number"},
        units={name: unit for name, unit in zip(joints, robot.position_units)} | {"load_kg": "kg"},
    )
    q = frame[joints].to_numpy(dtype=float) * robot.position_scale
    for line, row in zip(frame.index, q):
        robot.check_limits(row, source=source, line=int(line))
    load = None
    if "load_kg" in frame:
        bad = frame.index[frame["load_kg"] <= 0]
        if len(bad):
            raise InputError(
                f"expected a positive mass in kg, got {frame.at[bad[0], 'load_kg']:g}",
                source=source,
                line=int(bad[0]),
                column="load_kg",
            )
        load = frame["load_kg"].to_numpy(dtype=float)
        if max_load_kg is not None and np.any(load > max_load_kg):
            row = int(np.argmax(load > max_load_kg))
            raise InputError(
                f"a load of {load[row]:g} kg is more than the {max_load_kg:.0f} kg the arm can plausibly carry: "
                "is load_kg in another unit than kg?",
                source=source,
                line=int(frame.index[row]),
                column="load_kg",
            )
    prismatic = robot.prismatic.copy() if robot.prismatic.any() else None
    return Plan(q=q, load_kg=load, lines=frame.index.to_numpy(dtype=int), source=source, prismatic=prismatic)


def write_plan(plan: Plan, path: str | PathLike[str], *, comments: Sequence[str] = ()) -> None:
    """Write ``plan`` in the format :func:`read_plan` reads; ``comments`` become leading ``#`` lines.

    Joint angles are written with 3 decimals in deg (about 17 μrad, far below the
    controllers' repeatability), prismatic joints' positions with 3 decimals in mm,
    loads with 1 decimal in kg.
    """
    lines = [f"# {line}" for comment in comments for line in str(comment).splitlines()]
    prismatic = np.zeros(plan.q.shape[1], dtype=bool) if plan.prismatic is None else plan.prismatic
    joints = [f"q{j + 1}_{'mm' if linear else 'deg'}" for j, linear in enumerate(prismatic)]
    scale = np.where(prismatic, MM, DEG)
    lines.append(",".join(joints + ([] if plan.load_kg is None else ["load_kg"])))
    for number, q in enumerate(plan.q):
        # "+ 0.0" turns a rounded -0.0 into 0.0 so the file does not depend on rounding sign.
        fields = [f"{round(float(value / unit), 3) + 0.0:.3f}" for value, unit in zip(q, scale)]
        if plan.load_kg is not None:
            fields.append(f"{float(plan.load_kg[number]):.1f}")
        lines.append(",".join(fields))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")
