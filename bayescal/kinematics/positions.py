"""Positions files: measured markers, one row per marker per configuration.

A positions file is a CSV with columns ``q1_deg..qn_deg`` (the cell's commanded
joints, in its ``[robot] joints`` order), ``marker`` (a name of the cell's
``[markers]``) and ``x_mm, y_mm, z_mm`` (the marker in the tracker frame).  The
rows of one configuration share their joint angles and name every marker of the
cell once.  A configurations file (``bayescal predict``) has the same rows without
the positions.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import numpy as np

from bayescal.cell.joint_tables import JointLayout, read_joint_table
from bayescal.errors import InputError
from bayescal.kinematics.cell import PointsCell
from bayescal.tables import ColumnKind
from bayescal.units import DEG, MM

__all__ = ["Positions", "read_positions", "POSITION_COLUMNS"]

POSITION_COLUMNS = ("x_mm", "y_mm", "z_mm")

SMALLEST_SPREAD_MM = 10.0
"""Positions spread over less than 10 mm are taken for metres: a robot's campaign spreads its markers over hundreds of mm."""


@dataclass(frozen=True)
class Positions:
    """Measured (or asked-for) marker positions, SI.

    Attributes
    ----------
    joints : numpy.ndarray
        ``(N, n_commanded)`` commanded joint angles (rad), one row per configuration.
    xyz : numpy.ndarray or None
        ``(N, M, 3)`` positions in the tracker frame (m), markers in the cell's order; ``None`` for a configurations file.
    lines : numpy.ndarray
        ``(N, M)`` each value's line in the file.
    rows : numpy.ndarray
        ``(N, M)`` each value's row among the file's data rows (0 first), to write results in the file's order.
    source : str
    """

    joints: np.ndarray
    xyz: np.ndarray | None
    lines: np.ndarray
    rows: np.ndarray
    source: str = ""

    def take(self, index: np.ndarray) -> Positions:
        """The configurations ``index`` (a fold)."""
        return Positions(self.joints[index], None if self.xyz is None else self.xyz[index], self.lines[index], self.rows[index], self.source)

    def __len__(self) -> int:
        return len(self.joints)


def read_positions(path: str | PathLike[str], cell: PointsCell, *, measured: bool = True) -> Positions:
    """Read a positions file (``measured``) or a configurations file for ``cell``.

    Raises
    ------
    InputError
        Naming the file, line and column: joint columns that do not match the cell's
        commanded joints (count or unit) or angles that look like radians (the checks of
        every joint-angle table, :mod:`bayescal.cell.joint_tables`), an unknown marker, a
        configuration missing a marker or naming one twice, positions that look like metres.
    """
    source = str(path)
    expected = cell.joint_columns
    layout = JointLayout(tuple(expected), np.full(len(expected), DEG), f"the cell ({cell.source}, [robot] joints)", verb="commands")
    columns: dict[str, ColumnKind] = {"marker": "text"}
    if measured:
        columns |= {name: "number" for name in POSITION_COLUMNS}
    what = "positions file" if measured else "configurations file"
    frame, q = read_joint_table(path, layout, columns, what=what, units={name: "mm" for name in POSITION_COLUMNS})
    known = cell.marker_names
    for line, name in frame["marker"].items():
        if name not in known:
            raise InputError(f"unknown marker '{name}'; the cell's markers are {', '.join(known)}", source=source, line=line, column="marker")
    angles = frame[list(expected)].to_numpy()
    groups: dict[tuple, dict[str, int]] = {}
    for row, (line, name) in enumerate(frame["marker"].items()):
        key = tuple(angles[row])
        seen = groups.setdefault(key, {})
        if name in seen:
            raise InputError(f"marker '{name}' is measured twice in the configuration of line {frame.index[seen[name]]}",
                             source=source, line=line, column="marker")
        seen[name] = row
    for seen in groups.values():
        missing = [name for name in known if name not in seen]
        if missing:
            first = frame.index[min(seen.values())]
            raise InputError(f"the configuration of this line has no row for marker '{missing[0]}' (each configuration needs one "
                             f"row per marker: {', '.join(known)})", source=source, line=first, column="marker")
    order = [[seen[name] for name in known] for seen in groups.values()]
    joints = np.array([q[rows[0]] for rows in order])
    lines = np.array([[frame.index[r] for r in rows] for rows in order])
    xyz = None
    if measured:
        values = frame[list(POSITION_COLUMNS)].to_numpy()
        if np.ptp(values, axis=0).max() < SMALLEST_SPREAD_MM and len(values) > 1:
            raise InputError(f"the positions spread over less than {SMALLEST_SPREAD_MM:g} mm: metres? write them in mm",
                             source=source, column="x_mm")
        xyz = values[np.array(order)] * MM
    return Positions(joints=joints, xyz=xyz, lines=lines, rows=np.array(order), source=source)
