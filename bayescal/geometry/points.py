"""Marker points on the compensator, as a laser tracker gives them (Klimchik et al., Table I), and their reader.

``P1`` sits on the compensator's pivot on link 2; ``P01``, ``P02``, … on the
compensator cylinder.  :func:`read_arc_points` reads a ``q2_deg, marker, x_mm,
y_mm[, z_mm]`` file into :class:`MarkerPoints` (SI), refusing points in another
unit or angles in radians with one line naming the file, row and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from os import PathLike

import numpy as np
from numpy.typing import ArrayLike

from bayescal.errors import InputError
from bayescal.geometry.plausibility import check_angle_unit
from bayescal.tables import read_table
from bayescal.units import DEG, MM

__all__ = ["LEVER_MARKER", "MAX_POINT_DISTANCE", "MIN_POINT_SPREAD", "MarkerPoints", "read_arc_points"]

LEVER_MARKER = "P1"
"""Name of the marker on the compensator's pivot on link 2."""

_CYLINDER_MARKER = re.compile(r"P0\d+")
_MIN_POINTS = 3
# Points closer than this (in m) are treated as the same point.
_SAME_POINT = 1e-9
MIN_POINT_SPREAD = 10 * MM
"""Smallest plausible extent (m, bounding-box diagonal) of a file's tracker points.

A heavy robot's spring compensator is hundreds of mm long (KR-270: L = 184.7 mm,
|a| = 696 mm, Klimchik et al. Table II) and its markers' points spread over the
whole of it (Table I: 850 mm); the same points written in metres spread over
less than 1 mm."""
MAX_POINT_DISTANCE = 100.0
"""Largest plausible distance (m) of a tracker point from the tracker's origin.

Laser trackers measure within tens of metres (the AT901 class, whose noise the
cell models, within 80 m), so a larger coordinate is in another unit (μm)."""


@dataclass(frozen=True)
class MarkerPoints:
    """Tracker points of the compensator markers, SI.

    Attributes
    ----------
    marker
        Marker name of each point: ``"P1"`` or ``"P0<k>"``, shape ``(n,)``.
    q2
        Joint-2 angle of each point in rad, shape ``(n,)``.
    xyz
        Coordinates in m, shape ``(n, 2)`` (planar data) or ``(n, 3)``.
    line
        Line of each point in its file (or its 1-based row), for error messages.
    source
        The file the points came from, if any.
    """

    marker: np.ndarray
    q2: np.ndarray
    xyz: np.ndarray
    line: np.ndarray
    source: str | None = None

    @classmethod
    def from_arrays(
        cls, marker: ArrayLike, q2: ArrayLike, xyz: ArrayLike, *, line: ArrayLike | None = None, source: str | None = None
    ) -> MarkerPoints:
        """Check and wrap arrays (SI: rad, m); raises :class:`InputError` as the reader does."""
        marker = np.asarray(marker, dtype=str)
        q2 = np.asarray(q2, dtype=float)
        xyz = np.asarray(xyz, dtype=float)
        n = marker.size
        if marker.ndim != 1 or q2.shape != (n,) or xyz.ndim != 2 or xyz.shape[0] != n or xyz.shape[1] not in (2, 3):
            raise InputError(
                f"expected n markers, n angles and (n, 2) or (n, 3) coordinates, got shapes "
                f"{marker.shape}, {q2.shape}, {xyz.shape}",
                source=source,
            )
        line = np.arange(1, n + 1) if line is None else np.asarray(line, dtype=int)
        points = cls(marker, q2, xyz, line, source)
        points._check()
        return points

    @property
    def dim(self) -> int:
        """2 for planar data, 3 when z is given."""
        return self.xyz.shape[1]

    @property
    def cylinder_markers(self) -> list[str]:
        """Names of the cylinder markers (``P01``, ``P02``, …), sorted."""
        return sorted({str(m) for m in self.marker if m != LEVER_MARKER}, key=lambda m: (len(m), m))

    @property
    def markers(self) -> list[str]:
        """All marker names, the lever marker first."""
        return [LEVER_MARKER, *self.cylinder_markers]

    def of(self, marker: str) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (rad) and coordinates (m) of one marker's points."""
        mask = self.marker == marker
        return self.q2[mask], self.xyz[mask]

    def _check(self) -> None:
        def fail(what: str, rows: np.ndarray, column: str | None) -> InputError:
            return InputError(what, source=self.source, line=int(self.line[rows][0]), column=column)

        if not (np.all(np.isfinite(self.q2)) and np.all(np.isfinite(self.xyz))):
            bad = np.flatnonzero(~(np.isfinite(self.q2) & np.all(np.isfinite(self.xyz), axis=1)))
            raise fail("expected finite numbers", bad, None)
        for i, name in enumerate(self.marker):
            if name != LEVER_MARKER and not _CYLINDER_MARKER.fullmatch(name):
                raise fail(f"unknown marker '{name}': expected P1 (lever) or P01, P02, … (cylinder)", np.array([i]), "marker")
        if LEVER_MARKER not in self.marker:
            raise InputError("no P1 rows: the lever marker P1 is needed to find p2 and L", source=self.source, column="marker")
        if not self.cylinder_markers:
            raise InputError("no P0<k> rows: at least one cylinder marker (P01, …) is needed to find p0", source=self.source, column="marker")
        for name in self.markers:
            rows = np.flatnonzero(self.marker == name)
            q2 = self.q2[rows]
            _, first = np.unique(q2, return_index=True)
            if first.size != rows.size:
                repeated = np.setdiff1d(np.arange(rows.size), first)[0]
                raise fail(f"marker {name} has two rows at q2 = {q2[repeated] / DEG:g} deg", rows[[repeated]], "q2_deg")
            if rows.size < _MIN_POINTS:
                what = "angle" if name == LEVER_MARKER else "point"
                raise fail(
                    f"marker {name} has {rows.size} {what}{'' if rows.size == 1 else 's'}; an arc needs at least {_MIN_POINTS}",
                    rows,
                    "q2_deg" if name == LEVER_MARKER else "marker",
                )
            xyz = self.xyz[rows]
            centred = xyz - xyz.mean(axis=0)
            singular = np.linalg.svd(centred, compute_uv=False)
            if singular[0] < _SAME_POINT:
                raise fail(f"all points of marker {name} are identical: an arc needs distinct points", rows, "x_mm")
            if singular[1] < 1e-9 * singular[0]:
                raise fail(f"the points of marker {name} are collinear: no circle passes through them", rows, "x_mm")


def read_arc_points(path: str | PathLike[str]) -> MarkerPoints:
    """Read tracker points of the compensator markers from a CSV file.

    Parameters
    ----------
    path
        CSV file with columns ``q2_deg, marker, x_mm, y_mm`` and optionally
        ``z_mm``; one row per marker per joint angle; ``#`` lines are comments.

    Returns
    -------
    MarkerPoints
        In SI units (rad, m).

    Raises
    ------
    InputError
        A one-line message naming the file, line and column: missing file or
        column, a value that is not a finite number, an unknown marker, no P1
        or no P0<k> rows, a marker with fewer than 3 points (P1: 3 angles), a
        repeated angle, a marker whose points are identical or collinear, or
        coordinates in another unit than mm (all points within
        :data:`MIN_POINT_SPREAD`, or one beyond :data:`MAX_POINT_DISTANCE`).
    """
    units = {"q2_deg": "deg", "x_mm": "mm", "y_mm": "mm", "z_mm": "mm"}
    frame = read_table(
        path,
        {"q2_deg": "number", "marker": "text", "x_mm": "number", "y_mm": "number"},
        optional={"z_mm": "number"},
        units=units,
    )
    columns = ["x_mm", "y_mm", "z_mm"] if "z_mm" in frame else ["x_mm", "y_mm"]
    _check_scale(frame[columns].to_numpy() * MM, frame.index.to_numpy(), columns, str(path))
    check_angle_unit(frame, columns, str(path))
    return MarkerPoints.from_arrays(
        frame["marker"].to_numpy(dtype=str),
        frame["q2_deg"].to_numpy() * DEG,
        frame[columns].to_numpy() * MM,
        line=frame.index.to_numpy(),
        source=str(path),
    )


def _check_scale(xyz: np.ndarray, lines: np.ndarray, columns: list[str], source: str) -> None:
    """Reject coordinates (m) whose extent fits no compensator: a file written in metres or μm."""
    distance = np.linalg.norm(xyz, axis=1)
    far = int(np.argmax(distance))
    if distance[far] > MAX_POINT_DISTANCE:
        raise InputError(
            f"a point {distance[far]:.4g} m from the tracker, beyond any tracker's range ({MAX_POINT_DISTANCE:g} m): "
            f"are {', '.join(columns)} in another unit than mm (μm)?",
            source=source,
            line=int(lines[far]),
            column=columns[int(np.argmax(np.abs(xyz[far])))],
        )
    spread = float(np.linalg.norm(np.ptp(xyz, axis=0)))
    if len(xyz) >= 2 and spread < MIN_POINT_SPREAD:
        raise InputError(
            f"all points lie within {spread / MM:.3g} mm of each other, less than any compensator "
            f"({MIN_POINT_SPREAD / MM:g} mm): are {', '.join(columns)} in metres instead of mm?",
            source=source,
            line=int(lines[0]),
            column=columns[0],
        )
