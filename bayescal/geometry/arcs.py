"""Closed-form identification of the compensator geometry from laser-tracker arcs (eqs 10-29).

The data are tracker coordinates of markers on the compensator at several
joint-2 angles (Klimchik et al., Table I):

* ``P1`` sits on the compensator's pivot on link 2; it turns about the joint-2
  axis through P2 by the known joint angle, so its points fit the known-angle
  arc model of eq 10, ``p_i = mu R u_i + t`` with ``u_i = [cos q_i, sin q_i]``,
  solved in closed form by the Procrustes/SVD solution of eqs 11-19;
* ``P01``, ``P02``, … sit on the compensator cylinder, which turns about its
  fixed pivot P0 by angles that are not measured; their points fit concentric
  arcs about P0 (eqs 20-24), in 3D when z is given (with the axis ambiguity of
  eq 25 resolved by eqs 26-29).

The geometry follows as ``L = mu``, ``(a_x, a_y) = p2 - p0`` projected on the
tracker's X and Y axes, and the lever angle ``phi`` of
:mod:`bayescal.robot.compensator` from ``R``.  Everything is SI inside; the reader
converts the file's mm and degrees.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from bayescal.robot.compensator import CompensatorGeometry
from bayescal.geometry.layout import circular_mean, cylinder_direction, cylinder_points, lever_angle, lever_points, marker_offset
# The points and their reader live in geometry/points.py; they are named here too, beside the fits.
from bayescal.geometry.points import LEVER_MARKER, MarkerPoints, read_arc_points
from bayescal.units import DEG, MM

__all__ = [
    "LEVER_MARKER",
    "MarkerPoints",
    "read_arc_points",
    "KnownAngleFit",
    "known_angle_fit",
    "ConcentricFit",
    "concentric_fit",
    "GeometryFit",
    "CompensatorGeometryModel",
    "MarkerLayout",
]

@dataclass(frozen=True)
class KnownAngleFit:
    """The known-angle arc fit of eqs 10-19.

    Attributes
    ----------
    centre
        Arc centre ``t`` (p2 for the lever marker), shape ``(2,)`` or ``(3,)``.
    radius
        Scale factor ``mu`` (L for the lever marker).
    R
        The orthogonal map of eq 19 restricted to the plane of ``u``: shape
        ``(2, 2)`` for planar data, ``(3, 2)`` (orthonormal columns) in 3D.
    sense
        +1 when the points turn counter-clockwise in (X, Y) as q increases
        (``R`` a rotation), -1 when clockwise (``R`` a reflection).
    phi
        Angle of ``R·[1, 0]`` in (X, Y), counter-clockwise from X, in rad: the
        arc's direction from its centre at q = 0.
    residuals
        ``p_i - (mu R u_i + t)``, shape ``(n, dim)``.
    axis
        Unit normal of the arc's plane along which the arc turns
        counter-clockwise (``R e1 × R e2``); ``[0, 0, ±1]`` for planar data.
    """

    centre: np.ndarray
    radius: float
    R: np.ndarray
    sense: int
    phi: float
    residuals: np.ndarray
    axis: np.ndarray

    @property
    def rms(self) -> float:
        """Root mean square of the residual vectors' lengths."""
        return float(np.sqrt(np.mean(np.sum(self.residuals**2, axis=1))))

    def predict(self, q: ArrayLike) -> np.ndarray:
        """Fitted points at angles ``q`` (rad)."""
        q = np.asarray(q, dtype=float)
        u = np.stack([np.cos(q), np.sin(q)], axis=-1)
        return self.centre + self.radius * u @ self.R.T


def known_angle_fit(q: ArrayLike, points: ArrayLike) -> KnownAngleFit:
    """Fit a circle arc to points whose angles are known: eqs 10-19.

    Minimises ``Σ |p_i - mu R u_i - t|²`` over the scale ``mu``, the
    orthogonal ``R`` (rotation or reflection) and the centre ``t``, with
    ``u_i = [cos q_i, sin q_i]``.  ``R`` comes from the SVD of
    ``Σ û_i p̂_iᵀ`` (eqs 18-19); for 3D points ``R`` has two orthonormal
    columns and spans the arc's plane.

    Parameters
    ----------
    q
        Angles in rad, shape ``(n,)``, ``n >= 3``.
    points
        Points, shape ``(n, 2)`` or ``(n, 3)``.
    """
    q = np.asarray(q, dtype=float)
    p = np.asarray(points, dtype=float)
    if q.ndim != 1 or p.ndim != 2 or p.shape[0] != q.size or q.size < 3 or p.shape[1] not in (2, 3):
        raise ValueError(f"expected n >= 3 angles and (n, 2|3) points, got shapes {q.shape} and {p.shape}")
    u = np.column_stack([np.cos(q), np.sin(q)])
    u_hat = u - u.mean(axis=0)
    p_hat = p - p.mean(axis=0)
    U, _, Vt = np.linalg.svd(u_hat.T @ p_hat, full_matrices=False)
    R = Vt.T @ U.T
    mu = np.sum(p_hat * (u_hat @ R.T)) / np.sum(u_hat**2)
    t = p.mean(axis=0) - mu * R @ u.mean(axis=0)
    residuals = p - (mu * u @ R.T + t)
    R3 = R if p.shape[1] == 3 else np.vstack([R, np.zeros(2)])
    axis = np.cross(R3[:, 0], R3[:, 1])
    axis /= np.linalg.norm(axis)
    sense = 1 if axis[2] >= 0 else -1
    phi = math.atan2(R[1, 0], R[0, 0])
    return KnownAngleFit(t, float(mu), R, sense, phi, residuals, axis)


@dataclass(frozen=True)
class ConcentricFit:
    """Concentric arcs about one centre (eqs 20-29).

    Attributes
    ----------
    centre
        The common centre p0, shape ``(2,)`` or ``(3,)``.
    radii
        Radius of each marker's arc (eq 21), by marker name.
    residuals
        Radial residuals ``|p_i - p0| - R_j`` of each marker, by marker name.
    axis
        The rotation axis ``n`` of eq 25 (3D data), or ``None`` in the plane.
    """

    centre: np.ndarray
    radii: dict[str, float]
    residuals: dict[str, np.ndarray]
    axis: np.ndarray | None = None

    def rms(self, marker: str) -> float:
        """Root mean square radial residual of one marker."""
        return float(np.sqrt(np.mean(self.residuals[marker] ** 2)))


def concentric_fit(point_sets: Mapping[str, ArrayLike]) -> ConcentricFit:
    """Fit concentric arcs with a common centre to several point sets: eqs 20-29.

    In the plane the normal equations (24) have a unique solution.  In 3D
    they determine the centre only up to a shift along the rotation axis
    ``n`` (eq 25), taken as the eigenvector of the smallest eigenvalue of
    ``Σ p̂ p̂ᵀ``; the shift is fixed by minimising ``Σ R_j²`` (eqs 26-29),
    which puts the centre at the mean position of all points along ``n``.

    Parameters
    ----------
    point_sets
        Marker name to points of shape ``(m_j, 2)`` or ``(m_j, 3)``, ``m_j >= 3``.
    """
    sets = {name: np.asarray(p, dtype=float) for name, p in point_sets.items()}
    if not sets:
        raise ValueError("no point sets given")
    dims = {p.shape[1] for p in sets.values()}
    if len(dims) != 1 or not dims <= {2, 3} or any(p.shape[0] < 3 for p in sets.values()):
        raise ValueError("expected point sets of shape (m >= 3, 2) or (m >= 3, 3), all of the same dimension")
    dim = dims.pop()
    scatter = np.zeros((dim, dim))
    rhs = np.zeros(dim)
    for p in sets.values():
        p_hat = p - p.mean(axis=0)
        sq = np.sum(p**2, axis=1)
        scatter += p_hat.T @ p_hat
        rhs += 0.5 * p_hat.T @ (sq - sq.mean())
    if dim == 2:
        centre = np.linalg.solve(scatter, rhs)
        axis = None
    else:
        values, vectors = np.linalg.eigh(scatter)
        axis = vectors[:, 0] * (1.0 if vectors[2, 0] >= 0 else -1.0)
        # Eq 28 restricted to the plane orthogonal to the axis, where the system is regular.
        in_plane = vectors[:, 1:]
        p_c = in_plane @ ((in_plane.T @ rhs) / values[1:])
        # Eq 27: minimising the sum of the squared radii puts the centre at the mean of the arcs' own
        # centroids along the axis, which is the mean of all points only when every arc has as many points.
        centroid = np.mean([p.mean(axis=0) for p in sets.values()], axis=0)
        centre = (np.eye(3) - np.outer(axis, axis)) @ p_c + np.outer(axis, axis) @ centroid
    radii = {name: float(np.sqrt(np.mean(np.sum((p - centre) ** 2, axis=1)))) for name, p in sets.items()}
    residuals = {name: np.linalg.norm(p - centre, axis=1) - radii[name] for name, p in sets.items()}
    return ConcentricFit(centre, radii, residuals, axis)


@dataclass(frozen=True)
class GeometryFit:
    """Compensator geometry from the closed-form fits.

    Attributes
    ----------
    lever
        Known-angle fit of the P1 marker (centre p2, radius L).
    cylinder
        Concentric fit of the P0<k> markers (centre p0).
    geometry
        ``CompensatorGeometry(L, a_x, a_y, phi)`` in SI.
    residuals_rms
        Root mean square residual of each marker in m: the length of the
        residual vector for P1, the radial residual for the cylinder markers
        (whose tangential position the concentric model leaves free).
    mirrored
        True when the P1 arc turns counter-clockwise in the tracker's (x, y),
        so that y was taken as pointing down (see :class:`CompensatorGeometryModel`).
    source
        The data file, if any.
    """

    lever: KnownAngleFit
    cylinder: ConcentricFit
    geometry: CompensatorGeometry
    residuals_rms: dict[str, float]
    mirrored: bool = False
    source: str | None = None

    @property
    def p2(self) -> np.ndarray:
        """Centre of the lever arc (on the joint-2 axis), m."""
        return self.lever.centre

    @property
    def p0(self) -> np.ndarray:
        """Centre of the cylinder arcs (the compensator's fixed pivot), m."""
        return self.cylinder.centre

    @property
    def axis_tilt(self) -> float | None:
        """Angle in rad between the cylinder's rotation axis and the tracker's Z axis (3D data only)."""
        if self.cylinder.axis is None:
            return None
        return float(np.arccos(min(1.0, abs(self.cylinder.axis[2]))))

    def summary(self) -> pd.DataFrame:
        """The identified parameters in mm and deg.

        Returns
        -------
        pandas.DataFrame
            Indexed by parameter (``L, a_x, a_y, phi, alpha, p2_x, p2_y, p0_x,
            p0_y, R[<marker>], rms[<marker>]``), with columns ``value`` and ``unit``.
        """
        g = self.geometry
        rows = {
            "L": (g.L / MM, "mm"),
            "a_x": (g.a_x / MM, "mm"),
            "a_y": (g.a_y / MM, "mm"),
            "phi": (g.phi / DEG, "deg"),
            "alpha": (g.alpha / DEG, "deg"),
            "p2_x": (self.p2[0] / MM, "mm"),
            "p2_y": (self.p2[1] / MM, "mm"),
            "p0_x": (self.p0[0] / MM, "mm"),
            "p0_y": (self.p0[1] / MM, "mm"),
        }
        rows |= {f"R[{name}]": (radius / MM, "mm") for name, radius in self.cylinder.radii.items()}
        rows |= {f"rms[{name}]": (rms / MM, "mm") for name, rms in self.residuals_rms.items()}
        if self.axis_tilt is not None:
            rows["axis_tilt"] = (self.axis_tilt / DEG, "deg")
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=["value", "unit"])
        frame.index.name = "parameter"
        return frame


class CompensatorGeometryModel:
    """The paper's two-step closed-form identification of L, a_x, a_y (and phi).

    ``CompensatorGeometryModel().fit(points)`` runs the known-angle fit on P1,
    the concentric fit on the P0<k> markers, and combines them.  The lever of
    the convention turns clockwise in (X, Y) as q2 grows (the best orthogonal
    ``R`` of eq 19 is a reflection, as on Table I); if it turns the other way
    the tracker frame is mirrored, y is read as pointing down and a
    ``UserWarning`` says so.
    """

    def fit(self, points: MarkerPoints) -> GeometryFit:
        """Identify the geometry from marker points (see :func:`read_arc_points`)."""
        q1, p1 = points.of(LEVER_MARKER)
        lever = known_angle_fit(q1, p1)
        cylinder = concentric_fit({name: points.of(name)[1] for name in points.cylinder_markers})
        a = lever.centre - cylinder.centre
        mirrored = lever.sense == 1
        if mirrored:
            # The convention has the lever turning clockwise in (X, Y) as q2 grows (Table I's
            # frame); a counter-clockwise arc means a mirrored frame, read here as Y pointing down.
            warnings.warn(
                "the P1 arc turns counter-clockwise in (x, y) as q2 increases, unlike Table I's frame; "
                "y is taken as pointing down (a_y and phi change sign)",
                UserWarning,
                stacklevel=2,
            )
        flip = -1.0 if mirrored else 1.0
        geometry = CompensatorGeometry(lever.radius, float(a[0]), flip * float(a[1]), flip * lever.phi)
        rms = {LEVER_MARKER: lever.rms} | {name: cylinder.rms(name) for name in points.cylinder_markers}
        return GeometryFit(lever, cylinder, geometry, rms, mirrored, points.source)


@dataclass(frozen=True)
class MarkerLayout:
    """Where the markers are at any joint angle: the ground truth of simulated points (SI, tracker frame;
    :func:`bayescal.twin.arcs.simulate_markers`).

    P1 is at ``p2 + L·[cos(phi + sense·q2), sin(phi + sense·q2)]``; each
    cylinder marker is rigid on the cylinder P0→P1, at distance ``radius``
    from p0 and angle ``offset`` from the cylinder's direction.

    Attributes
    ----------
    p2, p0
        Centres of the lever and cylinder arcs, shape ``(2,)``.
    L, phi, sense
        Lever length, lever angle at q2 = 0 in the tracker frame, and the
        arc's sense (-1: clockwise as on Table I).
    cylinder
        Marker name to ``(radius, offset)`` in m and rad.
    """

    p2: np.ndarray
    L: float
    phi: float
    sense: int
    p0: np.ndarray
    cylinder: dict[str, tuple[float, float]]

    @classmethod
    def from_fit(cls, fit: GeometryFit, points: MarkerPoints) -> MarkerLayout:
        """The layout of a closed-form fit, each marker's offset the circular mean over its points."""
        lever = fit.lever
        layout = cls(lever.centre[:2], lever.radius, lever.phi, lever.sense, fit.p0[:2], {})
        for name in points.cylinder_markers:
            q2, xyz = points.of(name)
            offset = marker_offset(xyz[:, 0], xyz[:, 1], fit.p0[0], fit.p0[1], layout._cylinder_direction(q2))
            layout.cylinder[name] = (fit.cylinder.radii[name], circular_mean(offset))
        return layout

    def _lever_points(self, q2: np.ndarray) -> np.ndarray:
        return np.column_stack(lever_points(self.p2[0], self.p2[1], self.L, lever_angle(self.phi, self.sense, q2)))

    def _cylinder_direction(self, q2: np.ndarray) -> np.ndarray:
        lever = self._lever_points(q2)
        return cylinder_direction(lever[:, 0], lever[:, 1], self.p0[0], self.p0[1])

    def positions(self, q2: ArrayLike) -> dict[str, np.ndarray]:
        """Exact marker positions at joint angles ``q2`` (rad), by marker, shape ``(n, 2)`` each (:mod:`bayescal.geometry.layout`)."""
        q2 = np.atleast_1d(np.asarray(q2, dtype=float))
        out = {LEVER_MARKER: self._lever_points(q2)}
        direction = self._cylinder_direction(q2)
        for name, (radius, offset) in self.cylinder.items():
            x, y, _ = cylinder_points(self.p0[0], self.p0[1], direction, radius, offset)
            out[name] = np.column_stack([x, y])
        return out
