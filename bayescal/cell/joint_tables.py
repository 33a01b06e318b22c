"""Joint-angle tables: the CSV files whose every row holds one configuration of a robot's joints.

Campaigns (:mod:`bayescal.cell.campaign`), machining programs
(:mod:`bayescal.compensation.program`), joint sweeps (:mod:`bayescal.registration.sweeps`)
and positions files (:mod:`bayescal.kinematics.positions`) carry the columns
``q1_deg .. qn_deg`` (``q<j>_mm`` for a prismatic joint) beside columns of their own
kind.  Each reads them through :func:`read_joint_table`, which applies one set of
checks, each naming the file, the line and the column of the first value at fault:

* the joint columns are those of the robot, one per joint and in its unit: a
  ``q7_deg`` on a six-joint robot, a missing ``q6_deg`` or a ``q2_rad`` is refused;
* no column bears a name the command's output writes (its values would be overwritten);
* every row lies within the joint limits;
* the angles are not written in radians: a table of two or more configurations whose
  every angle lies within ±:data:`RADIAN_SPAN` deg (within its limit in rad for a joint
  that turns farther than ±π) is (a sweep, which may move one joint a few degrees about
  an all-zero home pose, judges its unit by its circles instead);
* a tool point (flange frame) lies within the robot's reach (:func:`check_tool_points`, which
  the readers of tables with one call: a program's ``tcp_*_mm``, a campaign's ``load_*_mm``).

Metres and N·mm are judged on each table's own physical columns, by the reader of that
table: a campaign's marker positions and wrench, a program's wrench
(:func:`bayescal.cell.campaign_checks.check_wrench`), a sweep's or a positions file's spread.
"""

from __future__ import annotations

import warnings

import re
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np

from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot
from bayescal.tables import ColumnKind, read_columns, read_header, table_frame
from bayescal.units import DEG, MM

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["JointLayout", "read_joint_table", "read_joint_columns", "robot_reach", "check_tool_points", "RADIAN_SPAN", "JOINT_COLUMN"]

RADIAN_SPAN = 3.2
"""Joint angles (in the file's deg) all within ± this are most likely radians: π rad is 3.14, and a table of
configurations spread over a robot's workspace spans tens of degrees."""

JOINT_COLUMN = re.compile(r"q([0-9]+)_(deg|rad|mrad|urad|grad|mm|m|cm|um|in)")
"""A joint column: ``q<j>_`` and a unit of angle or length.  An output's ``q1_cmd_deg`` is not one, nor a
program's own ``q1_note``, carried to the output unchanged."""


@dataclass(frozen=True)
class JointLayout:
    """The joint columns a table of one robot must hold, and what bounds their values.

    Attributes
    ----------
    columns : tuple of str
        ``q1_deg`` … in joint order (``q<j>_mm`` for a prismatic joint).
    scale : numpy.ndarray
        ``(n,)`` SI value of one file unit of each column (:data:`~bayescal.units.DEG` or :data:`~bayescal.units.MM`).
    owner : str
        What fixes the joints, for the messages: ``"the robot (robots/kr270.urdf)"``; empty for a table
        read without its robot (:meth:`from_header`), whose columns are then checked against nothing.
    verb : str
        How the owner holds its joints: it ``"has"`` them, or a cell ``"commands"`` them.
    robot : Robot or None
        Gives the joint limits and the reach; None: a cell whose commanded joints are not its
        model's (no limit is checked).
    """

    columns: tuple[str, ...]
    scale: np.ndarray
    owner: str
    verb: str = "has"
    robot: Robot | None = None

    @classmethod
    def of(cls, robot: Robot) -> JointLayout:
        """The layout of ``robot``'s joints: its position columns and limits."""
        return cls(tuple(robot.position_columns), robot.position_scale.copy(), f"the robot ({robot.source})", robot=robot)

    @classmethod
    def from_header(cls, names: list[str]) -> JointLayout:
        """The consecutive ``q1_deg``/``q1_mm``, ``q2_…`` columns of a header, for a table read without its robot."""
        columns: list[str] = []
        while f"q{len(columns) + 1}_deg" in names or f"q{len(columns) + 1}_mm" in names:
            columns.append(f"q{len(columns) + 1}_{'mm' if f'q{len(columns) + 1}_mm' in names else 'deg'}")
        columns = columns or ["q1_deg"]
        return cls(tuple(columns), np.array([MM if name.endswith("_mm") else DEG for name in columns]), "")

    @property
    def revolute(self) -> np.ndarray:
        """``(n,)`` which columns hold angles (deg)."""
        return np.array([name.endswith("_deg") for name in self.columns], dtype=bool)

    @property
    def radian_bound(self) -> np.ndarray:
        """``(n,)`` the largest value (in the file's deg) an angle written in radians shows in each column:
        :data:`RADIAN_SPAN`, or the joint's farthest limit in rad for a joint that turns beyond ±π (6.11 for ±350 deg)."""
        if self.robot is None:
            return np.full(len(self.columns), RADIAN_SPAN)
        return np.maximum(RADIAN_SPAN, np.maximum(np.abs(self.robot.lower), np.abs(self.robot.upper)))


def robot_reach(robot: Robot) -> float:
    """The farthest (m) the flange can be from the robot's base, at any joint values.

    The flange's position is the sum of the chain's link offsets (each joint's
    placement in its parent's frame, then the flange's in the last joint's), each
    turned by the joints before it, plus the travel of any prismatic joint; by the
    triangle inequality it is no longer than the sum of their lengths.  For the
    KR-270 of ``data/kr270.toml`` that sum is 3.735 m (its data sheet's reach: 2.7 m).
    """
    model = robot.model
    links = sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(1, model.njoints))
    flange = float(np.linalg.norm(model.frames[model.getFrameId(robot.flange)].placement.translation))
    travel = float(np.sum(np.maximum(np.abs(robot.lower), np.abs(robot.upper))[robot.prismatic]))
    return links + flange + travel


def check_tool_points(robot: Robot, points: np.ndarray, lines: np.ndarray, columns: tuple[str, str, str], source: str) -> None:
    """Refuse a tool point (flange frame, m) farther from the flange than the robot reaches.

    A tool as long as the whole arm carries no load an arm could hold; such a
    point is a unit slip or a stray digit.

    Parameters
    ----------
    robot
        Gives the reach (:func:`robot_reach`).
    points
        ``(N, 3)`` tool points in the flange frame, m.
    lines
        ``(N,)`` each point's line in ``source``.
    columns
        The points' x, y, z columns, for the message.
    source
        The file.
    """
    reach = robot_reach(robot)
    distance = np.linalg.norm(points, axis=1)
    beyond = np.flatnonzero(distance > reach)
    if beyond.size:
        row = int(beyond[0])
        raise InputError(
            f"a tool point {distance[row]:.4g} m from the flange, farther than the robot reaches ({reach:.3f} m, the "
            f"sum of its links' lengths in {robot.source}): expected {', '.join(columns)} as the tool's point in the "
            "flange frame, in mm",
            source=source,
            line=int(lines[row]),
            column=columns[int(np.argmax(np.abs(points[row])))],
        )


def read_joint_columns(
    path: str | PathLike[str], layout: JointLayout, columns: Mapping[str, ColumnKind], *, what: str,
    optional: Mapping[str, ColumnKind] | None = None, units: Mapping[str, str] | None = None, reserved: Collection[str] = (),
    reserved_why: str = "", span_in_degrees: bool = True, limits_refuse: bool = True,
) -> tuple[np.ndarray, dict[str, list], np.ndarray]:
    """Read a joint-angle table with the checks of the module documentation, without pandas (:func:`read_joint_table`
    gives the frame).

    Parameters
    ----------
    path
        The CSV file.
    layout
        The joint columns to read and what bounds them.
    columns, optional, units
        The table's other columns, as :func:`~bayescal.tables.read_table` takes them.
    what
        The table's kind, for the messages: ``"campaign"``, ``"program"``, ``"sweep file"``.
    reserved
        Column names the table may not carry, and ``reserved_why`` why, completing "which …"
        (e.g. "the compensated file writes (its values would be overwritten)").
    span_in_degrees
        Refuse (for a layout with an owner) angles all within :attr:`JointLayout.radian_bound` as radians.
    limits_refuse
        Refuse a position outside the robot's joint limits (False: warn).

    Returns
    -------
    lines, values : numpy.ndarray, dict
        ``(N,)`` each row's 1-based line in the file; :func:`~bayescal.tables.read_columns`'s checked columns by name.
    q : numpy.ndarray
        ``(N, n)`` the joint positions of every row, SI (rad, m).

    Raises
    ------
    InputError
        Naming the file, line and column of the first fault.
    """
    source = str(path)
    _check_header(path, layout, what, reserved, reserved_why)
    joint_units = {name: name.rsplit("_", 1)[1] for name in layout.columns}
    lines, values = read_columns(path, dict.fromkeys(layout.columns, "number") | dict(columns), optional=optional, units=joint_units | dict(units or {}))
    # (N, n), each column a run of memory, as a frame's columns give it
    q = np.array([values[name] for name in layout.columns], dtype=float).T * layout.scale
    lines = np.array(lines, dtype=int)
    # Radians first: read as degrees, they may also fall outside a limit, which would hide the slip.
    if span_in_degrees and layout.owner:
        _check_radians(layout, q, lines, source)
    if layout.robot is not None:
        if limits_refuse:
            _check_limits(layout.robot, q, lines, source)
        else:
            _warn_limits(layout.robot, q, lines, source, what)
    return lines, values, q


def read_joint_table(path: str | PathLike[str], layout: JointLayout, columns: Mapping[str, ColumnKind], **options) -> tuple[pd.DataFrame, np.ndarray]:
    """:func:`read_joint_columns`'s table as :func:`~bayescal.tables.read_table`'s frame, indexed by line, and ``q``."""
    lines, values, q = read_joint_columns(path, layout, columns, **options)
    return table_frame(lines.tolist(), values, str(path)), q


def _check_header(path: str | PathLike[str], layout: JointLayout, what: str, reserved: Collection[str], reserved_why: str) -> None:
    """The header's joint columns are the layout's and it has no ``reserved`` column (see :func:`read_joint_table`)."""
    source = str(path)
    header = read_header(path)
    if header is not None and layout.owner:
        _check_joint_columns(header, layout, what, source)
    clash = None if header is None else next((name for name in header[1] if name in reserved), None)
    if clash is not None:
        raise InputError(f"the {what} has a column {clash}, which {reserved_why}: rename it", source=source, line=header[0], column=clash)


def _check_joint_columns(header: tuple[int, list[str]], layout: JointLayout, what: str, source: str) -> None:
    """The header's joint columns are the layout's, by index and unit."""
    line, names = header
    present = sorted({name for name in names if JOINT_COLUMN.fullmatch(name)}, key=lambda name: int(JOINT_COLUMN.fullmatch(name)[1]))
    expected = list(layout.columns)
    if not present or present == expected:
        return  # no joint column at all: read_table names the first one missing
    by_index = {int(JOINT_COLUMN.fullmatch(name)[1]): name for name in expected}
    other_unit = next((name for name in present if name not in expected and int(JOINT_COLUMN.fullmatch(name)[1]) in by_index), None)
    if other_unit is not None:
        right = by_index[int(JOINT_COLUMN.fullmatch(other_unit)[1])]
        raise InputError(
            f"the {what} has a column {other_unit} where {layout.owner} expects {right}: write joint "
            f"positions in {right.rsplit('_', 1)[1]} under the columns {expected[0]}..{expected[-1]}",
            source=source,
            line=line,
            column=other_unit,
        )
    extra = [name for name in present if name not in expected]
    missing = [name for name in expected if name not in present]
    problem = f"has no column {missing[0]}" if missing else f"has a column {extra[0]}"
    raise InputError(
        f"the {what} {problem} but {layout.owner} {layout.verb} {len(expected)} joints: expected the columns {expected[0]}..{expected[-1]}, found {', '.join(present)}",
        source=source,
        line=line,
        column=(missing or extra)[0],
    )


def _check_limits(robot: Robot, q: np.ndarray, lines: np.ndarray, source: str) -> None:
    """Every row within the joint limits; :meth:`Robot.check_limits` words the first row outside (with its slack)."""
    outside = np.flatnonzero(np.any((q < robot.lower) | (q > robot.upper), axis=1))
    for row in outside:
        robot.check_limits(q[row], source=source, line=int(lines[row]))


def _warn_limits(robot: Robot, q: np.ndarray, lines: np.ndarray, source: str, what: str) -> None:
    """Warn, once, of rows beyond the joint limits, for a table whose use is geometric (a sweep's axis fit needs no limit)."""
    outside = np.any((q < robot.lower) | (q > robot.upper), axis=0)
    if not outside.any():
        return
    j = int(np.flatnonzero(outside)[0])
    row = int(np.flatnonzero((q[:, j] < robot.lower[j]) | (q[:, j] > robot.upper[j]))[0])
    scale, unit = robot.position_scale[j], robot.position_units[j]
    warnings.warn(
        f"{source}:{int(lines[row])}: the {what} moves joint {robot.joint_names[j]} to {q[row, j] / scale:.3f} {unit}, beyond "
        f"its limits in {robot.source} ({robot.lower[j] / scale:.1f} to {robot.upper[j] / scale:.1f} {unit}): read as it is "
        "(the axis fit needs no limit); is the cell's URDF the swept robot's?",
        UserWarning,
        stacklevel=3,
    )


def _check_radians(layout: JointLayout, q: np.ndarray, lines: np.ndarray, source: str) -> None:
    """Refuse two or more configurations whose every angle lies within :attr:`JointLayout.radian_bound`."""
    revolute = layout.revolute
    angles = q[:, revolute] / DEG
    if not angles.size:
        return
    _, first = np.unique(angles, axis=0, return_index=True)
    bound = layout.radian_bound[revolute]
    if first.size >= 2 and np.all(np.abs(angles) <= bound):
        columns = [name for name in layout.columns if name.endswith("_deg")]
        wider = [f"{name} {limit:.3g}" for name, limit, used in zip(columns, bound, np.abs(angles).max(axis=0)) if used > RADIAN_SPAN]
        beyond = f" (and within their limits in rad: {', '.join(wider)})" if wider else ""
        raise InputError(
            f"every joint angle of the {first.size} configurations lies within ±{RADIAN_SPAN:g} deg{beyond}, as angles in "
            f"radians would: write {columns[0]}..{columns[-1]} in degrees",
            source=source,
            line=int(lines[np.min(first)]),
            column=columns[0],
        )
