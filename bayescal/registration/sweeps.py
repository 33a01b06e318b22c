"""Reading joint-sweep files: reflector readings taken while one joint at a time moves."""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.joint_tables import JointLayout, read_joint_table
from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot
from bayescal.tables import read_table
from bayescal.units import DEG, MM

__all__ = ["Sweeps", "read_sweeps", "MAX_JOINTS", "MIN_ANGLES", "MIN_SPREAD", "MAX_RADIUS"]

MAX_JOINTS = 12
"""Most joint-angle columns ``q1_deg … q12_deg`` a sweep file may hold."""

MIN_ANGLES = 3
"""Fewest distinct angles per reflector and joint that fix a circle with known angles."""

MIN_SPREAD = 10 * MM
"""Smallest extent (m, bounding-box diagonal) of a sweep file's readings: reflectors on a robot's tool swept
through a few degrees of two joints cover hundreds of mm; the same readings written in metres cover less than 10 mm."""

MAX_RADIUS = 10.0
"""Largest radius (m) of a reflector's circle about a joint axis: more than three times the reach of the
largest industrial arms (a KR 1000 titan: 3.2 m); a sweep with its angles written in rad reads as 57 times its radius."""

_STILL = 1e-6 * DEG
"""Largest change (rad) of a joint that is taken as not moving: below any controller's resolution."""


@dataclass(frozen=True)
class Sweeps:
    """Reflector readings of joint sweeps, SI units.

    Attributes
    ----------
    joint
        (n,) 0-based index of the joint that moves in each reading.
    q
        (n, m) joint angles of each reading, rad.
    marker
        (n,) reflector name of each reading.
    xyz
        (n, 3) reflector position in the tracker frame, m.
    line
        (n,) 1-based line of each reading in ``source``.
    source
        The file read.
    """

    joint: np.ndarray
    q: np.ndarray
    marker: np.ndarray
    xyz: np.ndarray
    line: np.ndarray
    source: str

    @property
    def swept_joints(self) -> list[int]:
        """0-based indices of the joints swept, ascending."""
        return sorted({int(j) for j in self.joint})

    def of(self, joint: int) -> Sweeps:
        """The readings of the sweep of ``joint`` (0-based)."""
        keep = self.joint == joint
        return Sweeps(self.joint[keep], self.q[keep], self.marker[keep], self.xyz[keep], self.line[keep], self.source)


def _sweep_table(path: str | PathLike[str], robot: Robot | None) -> tuple[pd.DataFrame, np.ndarray, list[str]]:
    """The sweep file's rows, its ``(R, m)`` joints (SI) and its joint columns: the robot's when given, else ``q1_deg … qm_deg``."""
    columns = {"joint": "integer", "marker": "text", "x_mm": "number", "y_mm": "number", "z_mm": "number"}
    position_units = {"x_mm": "mm", "y_mm": "mm", "z_mm": "mm"}
    if robot is not None:
        # An axis fit is geometry: angles beyond the URDF's limits (a sweep of ±360 deg where the URDF says ±350) are warned of, not refused.
        frame, q = read_joint_table(
            path, JointLayout.of(robot), columns, what="sweep file", units=position_units, span_in_degrees=False, limits_refuse=False
        )
        return frame, q, list(robot.position_columns)
    q_columns = {f"q{k}_deg": "number" for k in range(1, MAX_JOINTS + 1)}
    frame = read_table(path, columns, optional=q_columns, units=position_units | {c: "deg" for c in q_columns})
    present = [c for c in q_columns if c in frame]
    expected = [f"q{k}_deg" for k in range(1, len(present) + 1)]
    if not present or present != expected:
        raise InputError(f"expected joint-angle columns q1_deg … qm_deg without gaps, got {present or 'none'}", source=str(path), line=1)
    return frame, frame[present].to_numpy() * DEG, present


def read_sweeps(path: str | PathLike[str], robot: Robot | None = None) -> Sweeps:
    """Read a sweep file.

    Parameters
    ----------
    path
        CSV file with columns ``joint`` (1-based index of the joint that
        moves), ``q1_deg … qm_deg``, ``marker``, ``x_mm, y_mm, z_mm`` (tracker
        frame); one row per reflector reading; ``#`` lines are comments.
    robot
        The robot swept; when given, the joint columns are checked as every
        joint-angle table's (:func:`~bayescal.cell.joint_tables.read_joint_table`:
        the robot's joints; beyond its limits only warned of).  Their unit is judged by the
        reflectors' circles (:data:`MAX_RADIUS`), not by their span: a sweep
        may move one joint a few degrees about an all-zero home pose.

    Returns
    -------
    Sweeps
        In SI units (rad, m).

    Raises
    ------
    InputError
        One line naming the file, line and column: a missing column or bad
        value, joint columns other than the robot's (a joint beyond its limits is
        warned of: the axis fit needs none), a joint index outside ``1 … m``, a sweep in which another joint than the
        named one moves, a reflector swept through fewer than :data:`MIN_ANGLES`
        angles.
    """
    source = str(path)
    frame, q, present = _sweep_table(path, robot)
    lines = frame.index.to_numpy()
    joint = frame["joint"].to_numpy(dtype=int)
    bad = np.flatnonzero((joint < 1) | (joint > len(present)))
    if bad.size:
        raise InputError(
            f"expected a joint index 1 … {len(present)}, got {joint[bad[0]]}", source=source, line=int(lines[bad[0]]), column="joint"
        )
    sweeps = Sweeps(joint - 1, q, frame["marker"].to_numpy(dtype=str), frame[["x_mm", "y_mm", "z_mm"]].to_numpy() * MM, lines, source)
    spread = float(np.linalg.norm(np.ptp(sweeps.xyz, axis=0)))
    if spread < MIN_SPREAD:
        raise InputError(f"all readings lie within {spread / MM:.3g} mm of each other, less than any swept tool "
                         f"({MIN_SPREAD / MM:g} mm): are x_mm, y_mm, z_mm in metres instead of mm?", source=source, line=int(lines[0]),
                         column="x_mm")
    for j in sweeps.swept_joints:
        _check_sweep(sweeps.of(j), j)
    return sweeps


def _check_sweep(sweep: Sweeps, j: int) -> None:
    """Reject a sweep of joint ``j`` in which another joint moves or a reflector has too few angles."""
    others = np.delete(sweep.q, j, axis=1)
    moved = np.abs(others - others[0]) > _STILL
    if moved.any():
        row, col = np.argwhere(moved)[0]
        k = col if col < j else col + 1
        raise InputError(
            f"in the sweep of joint {j + 1} joint {k + 1} moves too ({np.degrees(others[row, col]):.6g} deg "
            f"against {np.degrees(others[0, col]):.6g} deg on line {sweep.line[0]}): sweep one joint at a time",
            source=sweep.source, line=int(sweep.line[row]), column=f"q{k + 1}_deg",
        )
    for name in dict.fromkeys(sweep.marker):
        rows = sweep.marker == name
        angles = np.unique(np.round(sweep.q[rows, j] / _STILL))
        if angles.size < MIN_ANGLES:
            raise InputError(
                f"reflector '{name}' is read at {angles.size} angle(s) of joint {j + 1}, "
                f"expected at least {MIN_ANGLES} to fix its circle",
                source=sweep.source, line=int(sweep.line[np.flatnonzero(rows)[0]]), column=f"q{j + 1}_deg",
            )
        _check_radius(sweep, j, np.flatnonzero(rows), name)


def _check_radius(sweep: Sweeps, j: int, rows: np.ndarray, name: str) -> None:
    """Reject a reflector that moves too far for how little its joint turns: angles written in rad.

    A point on a circle of radius r moves by a chord of at most r·Δq when the joint turns by Δq,
    so chord / Δq is a lower bound of the radius.
    """
    q, xyz = sweep.q[rows, j], sweep.xyz[rows]
    a, b = np.triu_indices(rows.size, k=1)
    turn = np.abs(q[a] - q[b])
    usable = turn > _STILL
    if not usable.any():
        return
    radius = np.linalg.norm(xyz[a] - xyz[b], axis=1)[usable] / turn[usable]
    if radius.max() > MAX_RADIUS:
        raise InputError(
            f"reflector '{name}' moves as if on a circle of radius {radius.max():.3g} m or more about joint {j + 1}, "
            f"beyond any robot's reach ({MAX_RADIUS:g} m): is q{j + 1}_deg in deg, not rad?",
            source=sweep.source, line=int(sweep.line[rows[b[usable][int(np.argmax(radius))]]]), column=f"q{j + 1}_deg",
        )
