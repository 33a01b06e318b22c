"""The campaign CSV: laser-tracker positions of tool markers before and after loading.

This is the exchange format for measured (or simulated) elastostatic calibration
data, one row per marker per repeat per configuration::

    config, repeat, q1_deg, ..., q6_deg, fx_N, fy_N, fz_N, mx_Nm, my_Nm, mz_Nm,
    marker, x0_mm, y0_mm, z0_mm, x1_mm, y1_mm, z1_mm

* ``config`` labels the robot configurations, ``repeat`` the repetitions of the
  unloaded/loaded measurement in that configuration (both whole numbers, any
  sign: they are labels, not counts);
* ``q<j>_deg`` are the controller's joint angles; a robot with another number of
  joints has columns ``q1_deg`` … ``q<n>_deg``, and a prismatic joint (a linear
  track) has ``q<j>_mm``, its position in mm;
* the wrench is the one applied to the robot, referred to the origin of the
  ``flange`` frame and expressed in the base axes (N, N·m);
* positions are in the robot base frame in mm, ``0`` unloaded and ``1`` loaded;
* optional ``load_x_mm, load_y_mm, load_z_mm``: the point of the tool, in the
  flange frame, where the load's force acts (a hanging mass); without them the
  cell's tool load point is assumed.  A couple in the wrench beyond the force's
  moment about the flange origin acts as a dead couple;
* optional ``t0_s, t1_s``: when the unloaded and the loaded reading were taken,
  in seconds from any origin (a tracker's time stamps); with repeats of a
  configuration taken at different times, the model criticism measures the
  tracker's drift from them (``bayescal.critique.drift``); without times it
  cannot test for a drift.

Rows pair up when every row holds both its unloaded and its loaded position,
no (config, repeat, marker) appears twice, and all rows of a configuration
carry the same joint angles and the same wrench.  Lines starting with ``#`` are
provenance notes.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bayescal.cell.campaign_checks import check_deflection, check_wrench
from bayescal.cell.campaign_text import block_text, csv_line
from bayescal.cell.joint_tables import JointLayout, check_tool_points, read_joint_table
from bayescal.cell.loading import WRENCH_COLUMNS
from bayescal.cell.plan import position_columns
from bayescal.errors import InputError
from bayescal.tables import read_header
from bayescal.units import MM

if TYPE_CHECKING:
    import pandas as pd

    from bayescal.cell.config import Cell

__all__ = [
    "Campaign",
    "read_campaign",
    "write_campaign",
    "WRENCH_COLUMNS",
    "POSITION_COLUMNS",
    "LOAD_POINT_COLUMNS",
    "TIME_COLUMNS",
]

POSITION_COLUMNS = ("x0_mm", "y0_mm", "z0_mm", "x1_mm", "y1_mm", "z1_mm")
LOAD_POINT_COLUMNS = ("load_x_mm", "load_y_mm", "load_z_mm")
TIME_COLUMNS = ("t0_s", "t1_s")
_SAME_CONFIG_TOLERANCE = 1e-6
"""Largest difference (deg, N or N·m) between rows of one configuration still read as equal."""
_JOINT_COLUMN = re.compile(r"q([0-9]+)_(deg|mm)")


@dataclass(frozen=True, eq=False)
class Campaign:
    """Marker positions measured before and after loading, one entry per CSV row, in SI units.

    Attributes
    ----------
    config, repeat : numpy.ndarray of int, shape (N,)
    marker : numpy.ndarray of str, shape (N,)
    q : numpy.ndarray, shape (N, nq)
        Joint angles, rad.
    wrench : numpy.ndarray, shape (N, 6)
        ``[f (N); m (N·m)]`` at the flange origin, base axes.
    p0, p1 : numpy.ndarray, shape (N, 3)
        Unloaded and loaded marker positions in the base frame, m.
    lines : numpy.ndarray of int, shape (N,)
        Line numbers in the source file (0 for a campaign not read from a file).
    source : str
        The file the campaign was read from, or a description.
    load_point : numpy.ndarray or None, shape (N, 3)
        Flange-frame point (m) where each row's load force acts; None: not given
        (the cell's tool load point applies).
    prismatic : numpy.ndarray of bool or None, shape (nq,)
        Which joints are prismatic (positions in m, written in mm); None: all revolute.
    added_variance : numpy.ndarray or None, shape (N,)
        Variance (m²) per coordinate added to each row's deflection by the frame its positions
        were moved into (a tracker registration's uncertainty,
        :mod:`bayescal.registration.transfer`); None: none.
    """

    config: np.ndarray
    repeat: np.ndarray
    marker: np.ndarray
    q: np.ndarray
    wrench: np.ndarray
    p0: np.ndarray
    p1: np.ndarray
    lines: np.ndarray
    source: str = "<memory>"
    load_point: np.ndarray | None = None
    prismatic: np.ndarray | None = None
    added_variance: np.ndarray | None = None
    times: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = len(self.config)
        shapes = {
            "load_point": (n, 3) if self.load_point is not None else (),
            "repeat": (n,),
            "marker": (n,),
            "wrench": (n, 6),
            "p0": (n, 3),
            "p1": (n, 3),
            "lines": (n,),
            "added_variance": (n,) if self.added_variance is not None else (),
            "times": (n, 2) if self.times is not None else (),
        }
        for name, shape in shapes.items():
            if getattr(self, name) is not None and np.shape(getattr(self, name)) != shape:
                raise ValueError(f"Campaign.{name} has shape {np.shape(getattr(self, name))}, expected {shape}")
        if np.ndim(self.q) != 2 or len(self.q) != n:
            raise ValueError(f"Campaign.q has shape {np.shape(self.q)}, expected ({n}, nq)")

    def __len__(self) -> int:
        return len(self.config)

    @property
    def displacement(self) -> np.ndarray:
        """(N, 3) measured deflections ``p1 - p0`` of the markers, m."""
        return self.p1 - self.p0

    @property
    def n_equations(self) -> int:
        """Number of scalar equations (three coordinates per row), as counted by Klimchik et al."""
        return 3 * len(self)

    def to_frame(self) -> pd.DataFrame:
        """The campaign as the CSV's columns, in mm, deg, N and N·m."""
        import pandas as pd

        return pd.DataFrame(self.columns())

    def columns(self) -> dict[str, np.ndarray]:
        """The CSV's columns by name, in the file's order: mm, deg, N and N·m."""
        columns = {"config": self.config.astype(int), "repeat": self.repeat.astype(int)}
        names, scale = position_columns(self.q.shape[1], self.prismatic)
        columns |= dict(zip(names, (self.q / scale).T))
        columns |= dict(zip(WRENCH_COLUMNS, self.wrench.T))
        columns["marker"] = self.marker.astype(str)
        columns |= dict(zip(POSITION_COLUMNS, np.hstack([self.p0, self.p1]).T / MM))
        if self.load_point is not None:
            columns |= dict(zip(LOAD_POINT_COLUMNS, self.load_point.T / MM))
        if self.times is not None:
            columns |= dict(zip(TIME_COLUMNS, self.times.T))
        return columns


def write_campaign(campaign: Campaign, path: str | PathLike[str], *, comments: Sequence[str] = ()) -> None:
    """Write a campaign CSV; ``comments`` become leading ``#`` provenance lines.

    Joint angles are written with 6 decimals in deg, the wrench with 4 decimals
    in N and N·m, positions with 5 decimals in mm (10 nm), so that writing
    is deterministic and reading back reproduces the campaign to well below
    tracker resolution.  The rows are formatted :data:`WRITE_BLOCK` at a time
    (:func:`~bayescal.cell.campaign_text.block_text`).
    """
    named = campaign.columns()
    decimals = {name: 6 for name in named if _JOINT_COLUMN.fullmatch(name)}
    decimals |= {name: 4 for name in WRENCH_COLUMNS}
    decimals |= {name: 5 for name in POSITION_COLUMNS + LOAD_POINT_COLUMNS}
    columns = [(values, decimals.get(name)) for name, values in named.items()]
    with open(path, "w", encoding="utf-8") as file:
        file.writelines(f"# {line}\n" for comment in comments for line in str(comment).splitlines())
        file.write(csv_line(list(named)))
        for start in range(0, len(campaign), WRITE_BLOCK):
            file.write(block_text([(values[start : start + WRITE_BLOCK], places) for values, places in columns]))


WRITE_BLOCK = 10_000
"""Rows of a campaign formatted together: 100,000 configurations (900,000 rows, 135 MB of text) are written in
a small part of the memory the whole text would take."""


def _joint_layout(path: Path, cell: Cell | None) -> JointLayout:
    """The joint columns to read: the robot's, or without a cell the consecutive ``q<j>_deg``/``q<j>_mm`` of the header."""
    if cell is not None:
        return JointLayout.of(cell.robot)
    header = read_header(path)
    return JointLayout.from_header([] if header is None else header[1])


def read_campaign(
    path: str | PathLike[str],
    *,
    markers: Collection[str] | None = None,
    cell: Cell | None = None,
    to_base: Callable[[np.ndarray], np.ndarray] | None = None,
) -> Campaign:
    """Read and validate a campaign CSV.

    Parameters
    ----------
    path
        The CSV file (format in the module documentation).
    markers
        The marker names the tool carries; when given, any other name is an error.
    cell
        The cell the campaign was measured in; when given, the joint columns are
        checked as every joint-angle table's (:mod:`bayescal.cell.joint_tables`: one
        column per joint of its robot, within the joint limits, not in radians), a
        load point must lie within the robot's reach of the flange, and the wrench
        must be one the arm can carry (see :func:`~bayescal.cell.campaign_checks.check_wrench`).
    to_base
        Maps ``(N, 3)`` positions as read (m) into the base frame, before the
        checks that compare them with the wrench; None: the file is in the base
        frame (:mod:`bayescal.registration.transfer` passes a registered frame).

    Returns
    -------
    Campaign
        The rows in file order, converted to SI.

    Raises
    ------
    InputError
        Naming the line and column of the first problem: a missing column, a
        value that is not a number, a row whose unloaded and loaded positions do
        not pair up, a duplicated (config, repeat, marker), rows of a
        configuration that disagree on the joint angles or the wrench, an
        unknown marker, or loaded positions all equal to the unloaded ones;
        with ``cell``, also joint columns that do not match the robot, angles
        outside its limits or in radians, a load point beyond the robot's reach,
        and implausible wrenches.
    """
    source = str(path)
    layout = _joint_layout(Path(path), cell)
    prismatic = ~layout.revolute
    frame, q = _read_frame(path, layout)
    given, timed = _check_rows(frame, markers, list(layout.columns), cell, source)
    positions = _positions(frame, to_base, source)
    wrench, lines = frame[list(WRENCH_COLUMNS)].to_numpy(dtype=float), frame.index.to_numpy(dtype=int)
    if cell is not None:
        check_deflection(wrench, positions, lines, source)
    return Campaign(
        config=frame["config"].to_numpy(dtype=int), repeat=frame["repeat"].to_numpy(dtype=int),
        marker=frame["marker"].to_numpy(dtype=str), q=q, wrench=wrench, p0=positions[:, :3], p1=positions[:, 3:],
        lines=lines, source=source, load_point=frame[given].to_numpy(dtype=float) * MM if given else None,
        prismatic=prismatic if prismatic.any() else None,
        times=frame[list(TIME_COLUMNS)].to_numpy(dtype=float) if timed else None,
    )


def _check_rows(
    frame: pd.DataFrame, markers: Collection[str] | None, joint_columns: list[str], cell: Cell | None, source: str
) -> tuple[list[str], bool]:
    """:func:`read_campaign`'s checks of the rows as read; the load point's columns (or none) and whether rows are timed."""
    if markers is not None:
        _check_markers(frame, markers, source)
    _check_unique(frame, source)
    given = _all_or_none(frame, LOAD_POINT_COLUMNS, "the load point", source)
    timed = _all_or_none(frame, TIME_COLUMNS, "the reading times", source)
    if timed:
        _check_times(frame, source)
    _check_configurations(frame, joint_columns, given, cell, source)
    return given, timed


def _check_configurations(frame: pd.DataFrame, joint_columns: list[str], given: list[str], cell: Cell | None, source: str) -> None:
    """The rows of each configuration agree on its joints, wrench and load point; with ``cell``, the wrench is one
    the arm can carry and the load point within its reach."""
    n_joints = len(joint_columns)
    shared = joint_columns + list(WRENCH_COLUMNS) + given
    values = frame[shared].to_numpy(dtype=float)
    firsts = _configuration_rows(frame, values, shared, frame["config"].to_numpy(dtype=int), source)
    if cell is not None:
        check_wrench(cell, values[firsts, n_joints : n_joints + len(WRENCH_COLUMNS)], frame.index[firsts], source)
        if given:
            check_tool_points(cell.robot, values[firsts, -3:] * MM, frame.index[firsts], LOAD_POINT_COLUMNS, source)


def _read_frame(path: str | PathLike[str], layout: JointLayout) -> tuple[pd.DataFrame, np.ndarray]:
    """The campaign's rows, indexed by line, with its columns checked for type and unit, and its ``(N, nq)`` joints (SI)."""
    columns: dict[str, str] = {"config": "integer", "repeat": "integer"}
    columns |= {name: "number" for name in WRENCH_COLUMNS}
    columns["marker"] = "text"
    columns |= {name: "number" for name in POSITION_COLUMNS}
    units = {name: "N" for name in WRENCH_COLUMNS[:3]} | {name: "N·m" for name in WRENCH_COLUMNS[3:]}
    units |= {name: "mm" for name in POSITION_COLUMNS + LOAD_POINT_COLUMNS} | {name: "s" for name in TIME_COLUMNS}
    try:
        optional = {name: "number" for name in LOAD_POINT_COLUMNS + TIME_COLUMNS}
        return read_joint_table(path, layout, columns, what="campaign", optional=optional, units=units)
    except InputError as error:
        if error.column in POSITION_COLUMNS and error.what.startswith("missing value"):
            state = "unloaded" if error.column[1] == "0" else "loaded"
            raise InputError(
                f"the row has no {state} position ({error.what}): every row must pair an unloaded "
                "(x0_mm, y0_mm, z0_mm) and a loaded (x1_mm, y1_mm, z1_mm) position",
                source=error.source,
                line=error.line,
                column=error.column,
            ) from None
        raise


def _check_markers(frame: pd.DataFrame, markers: Collection[str], source: str) -> None:
    """Refuse a marker name the tool does not carry."""
    known = set(markers)
    for line, name in frame["marker"].items():
        if name not in known:
            raise InputError(
                f"unknown marker '{name}'; the tool carries {', '.join(sorted(known))}",
                source=source,
                line=int(line),
                column="marker",
            )


def _check_unique(frame: pd.DataFrame, source: str) -> None:
    """Refuse a (config, repeat, marker) read twice."""
    first_seen: dict[tuple, int] = {}
    for line, key in zip(frame.index, zip(frame["config"], frame["repeat"], frame["marker"])):
        if key in first_seen:
            raise InputError(
                f"config {key[0]}, repeat {key[1]}, marker '{key[2]}' already appears on line {first_seen[key]}: "
                "each marker is measured once per repeat",
                source=source,
                line=int(line),
                column="marker",
            )
        first_seen[key] = int(line)


def _all_or_none(frame: pd.DataFrame, names: tuple[str, ...], what: str, source: str) -> list[str]:
    """The columns of ``names`` the file gives: all of them or none."""
    given = [name for name in names if name in frame.columns]
    if given and len(given) < len(names):
        missing = next(name for name in names if name not in given)
        raise InputError(
            f"the campaign gives {', '.join(given)} but not {missing}: {what} needs all of {', '.join(names)}",
            source=source,
            column=missing,
        )
    return given


def _check_times(frame: pd.DataFrame, source: str) -> None:
    """Refuse a row whose loaded reading is stamped before its unloaded one."""
    early = frame["t1_s"].to_numpy(dtype=float) < frame["t0_s"].to_numpy(dtype=float)
    if early.any():
        line = int(frame.index[np.flatnonzero(early)[0]])
        raise InputError(
            "the loaded reading is stamped before the unloaded one (t1_s < t0_s); each row's t0_s is the time of its "
            "unloaded reading and t1_s of its loaded one, in seconds",
            source=source,
            line=line,
            column="t1_s",
        )


def _configuration_rows(frame: pd.DataFrame, values: np.ndarray, shared: list[str], config: np.ndarray, source: str) -> np.ndarray:
    """The first row of each configuration, in order; refuses rows of one configuration that disagree on ``shared``."""
    reference_row: dict[int, int] = {}
    for row, number in enumerate(config):
        first = reference_row.setdefault(int(number), row)
        difference = np.abs(values[row] - values[first])
        if np.any(difference > _SAME_CONFIG_TOLERANCE):
            column = shared[int(np.argmax(difference))]
            raise InputError(
                f"config {number} has {column} = {values[row, shared.index(column)]:g} here but "
                f"{values[first, shared.index(column)]:g} on line {int(frame.index[first])}: all rows of a configuration "
                "share its joint angles and wrench",
                source=source,
                line=int(frame.index[row]),
                column=column,
            )
    return np.array(sorted(reference_row.values()))


def _positions(frame: pd.DataFrame, to_base: Callable[[np.ndarray], np.ndarray] | None, source: str) -> np.ndarray:
    """``(N, 6)`` unloaded then loaded positions (m) in the base frame; refuses loaded columns copied from the unloaded."""
    positions = frame[list(POSITION_COLUMNS)].to_numpy(dtype=float) * MM
    if to_base is not None:
        positions = np.hstack([to_base(positions[:, :3]), to_base(positions[:, 3:])])
    if np.array_equal(positions[:, :3], positions[:, 3:]):
        raise InputError(
            "every loaded position x1_mm, y1_mm, z1_mm equals its unloaded x0_mm, y0_mm, z0_mm: no tracker reads a "
            "point twice to the last digit; were the unloaded columns copied into the loaded ones?",
            source=source,
            line=int(frame.index[0]),
            column="x1_mm",
        )
    return positions
