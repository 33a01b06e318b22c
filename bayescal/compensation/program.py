"""Machining program files: one row per pose, the programmed joints and the process wrench.

Columns: ``q1_deg .. qn_deg`` (the programmed joints), ``fx_N, fy_N, fz_N,
mx_Nm, my_Nm, mz_Nm`` (the process wrench on the tool, base axes, its moment
taken about the tool point) and optionally ``tcp_x_mm, tcp_y_mm, tcp_z_mm``
(the tool point in the flange frame; the cell's ``[tool] tcp_mm`` otherwise).
Other columns are carried to the compensated file unchanged; a column the
compensated file writes (:func:`compensated_columns`) is refused.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.campaign_checks import check_wrench
from bayescal.cell.loading import WRENCH_COLUMNS
from bayescal.cell.config import Cell
from bayescal.cell.joint_tables import JointLayout, check_tool_points, read_joint_table
from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.kinematics import Robot
from bayescal.units import MM

__all__ = ["Program", "read_program", "compensated_columns", "LENGTH_COLUMNS", "WRENCH_COLUMNS", "TCP_COLUMNS"]

TCP_COLUMNS = ("tcp_x_mm", "tcp_y_mm", "tcp_z_mm")


@dataclass(frozen=True)
class Program:
    """A machining program in SI, ``P`` poses.

    Attributes
    ----------
    q : numpy.ndarray
        ``(P, n)`` programmed joints, rad.
    wrench : numpy.ndarray
        ``(P, 6)`` process wrench ``[f (N); m (N·m)]`` in base axes, moment about the tool point.
    tcp : numpy.ndarray
        ``(P, 3)`` tool point in the flange frame, m.
    table : pandas.DataFrame
        The file's columns as read (indexed by line), carried to the output.
    source : str
        The file.
    """

    q: np.ndarray
    wrench: np.ndarray
    tcp: np.ndarray
    table: pd.DataFrame
    source: str = ""

    def __len__(self) -> int:
        return self.q.shape[0]

    @property
    def lines(self) -> np.ndarray:
        """``(P,)`` the line of each pose in the file (1-based, header included)."""
        return self.table.index.to_numpy(dtype=int)

    def flange_wrench(self, rotation: np.ndarray) -> np.ndarray:
        """``(P, 6)`` the wrench referred to the flange origin, given ``(P, 3, 3)`` flange rotations."""
        force = self.wrench[:, :3]
        arm = np.einsum("pij,pj->pi", rotation, self.tcp)
        return np.column_stack([force, self.wrench[:, 3:] + np.cross(arm, force)])


LENGTH_COLUMNS = ("deflection_mm", "error_rms_mm", "error_q95_mm", "error_q9973_mm", "error_q9973_identified_mm")
"""The compensated file's lengths, mm: the tool's deflection without compensation, the error left (rms, 95 % and
99.73 % of the draws) and the 99.73 % bound with the unidentified parameters held."""


def compensated_columns(robot: Robot) -> tuple[str, ...]:
    """The columns the compensated file adds to the program's, in order (:meth:`CompensationResults.table
    <bayescal.compensation.results.CompensationResults.table>` writes them): the joint targets, the lengths of
    :data:`LENGTH_COLUMNS`, the unidentified parameters' share and the flag.  A program may not carry them, or
    the compensated file would overwrite their values."""
    commands = tuple(f"q{j + 1}_cmd_{unit}" for j, unit in enumerate(robot.position_units))
    return commands + LENGTH_COLUMNS + ("unidentified_share", "flag")


def read_program(path: str | PathLike[str], cell: Cell) -> Program:
    """Read and check a program for ``cell``'s robot.

    The joint columns are checked as every joint-angle table's
    (:func:`~bayescal.cell.joint_tables.read_joint_table`): the robot's, within its
    limits, not in radians, and no column named as one the compensated file writes.

    Raises
    ------
    InputError
        A missing column or one the robot does not have, a column the compensated file
        writes, a bad number, joints outside the robot's limits or written in radians, a
        tool point beyond the robot's reach, or a force beyond what the robot can carry
        (naming the line and the column).
    """
    wrench_units = {name: name.rsplit("_", 1)[1] for name in WRENCH_COLUMNS}
    frame, q = read_joint_table(
        path,
        JointLayout.of(cell.robot),
        dict.fromkeys(WRENCH_COLUMNS, "number"),
        what="program",
        optional=dict.fromkeys(TCP_COLUMNS, "number"),
        units=wrench_units | dict.fromkeys(TCP_COLUMNS, "mm"),
        reserved=compensated_columns(cell.robot),
        reserved_why="the compensated file writes (its values would be overwritten)",
    )
    source = frame.attrs["source"]
    full = _all_columns(source, frame.index)
    wrench = frame[list(WRENCH_COLUMNS)].to_numpy(dtype=float)
    present = [name for name in TCP_COLUMNS if name in frame]
    if present and len(present) < 3:
        missing = next(name for name in TCP_COLUMNS if name not in frame)
        raise InputError(f"missing column '{missing}': a per-row tool point needs tcp_x_mm, tcp_y_mm and tcp_z_mm", source=source)
    tcp = frame[list(TCP_COLUMNS)].to_numpy(dtype=float) * MM if present else np.tile(cell.tool_point, (len(frame), 1))
    if present:
        check_tool_points(cell.robot, tcp, frame.index.to_numpy(dtype=int), TCP_COLUMNS, source)
    check_wrench(cell, wrench, frame.index.to_numpy(dtype=int), source, what="process", about="the tool point", smallest=False)
    return Program(q=q, wrench=wrench, tcp=tcp, table=full, source=source)


def _all_columns(source: str, lines: pd.Index) -> pd.DataFrame:
    """Every column of the file as text, indexed by line: what the compensated file carries over."""
    record_read(source, "the program")
    with open(source, encoding="utf-8-sig", newline="") as handle:
        numbered = [(i, line) for i, line in enumerate(handle.read().splitlines(), start=1) if line.strip() and not line.lstrip().startswith("#")]
    rows = list(csv.reader([line for _, line in numbered], skipinitialspace=True))
    header = [name.strip() for name in rows[0]]
    return pd.DataFrame([[field.strip() for field in row] for row in rows[1:]], columns=header, index=lines)
