"""Which configurations a calibration campaign can use: the constraints of eq 41 and of the cell.

A configuration ``q`` loaded with a mass hanging at the tool's load point (the
gravity-only loading of Klimchik et al.'s experiments), or, on a cell whose
end-effector applies them, with a force in any direction and a couple
(:mod:`bayescal.cell.loading`), is feasible when

* every joint is within its limits;
* the mass lies in the design's mass range; a force and a couple within the
  end-effector's ``force_max_N`` (eq 41's ``‖F‖ ≤ F_max``) and ``couple_max_Nm``,
  a force not straight down only on an end-effector that can apply it;
* every marker is visible from the tracker: the line of sight does not pass
  through the arm, and it meets the marker within the reflector's acceptance
  angle;
* no tool point (flange, markers, load point) is below the floor, and the
  hanging mass keeps a clearance above it;
* the loaded static equilibrium exists (Newton's method converges).

The KR-270 URDF carries no collision or visual geometry, so the arm is
approximated by capsules around the segments joining consecutive joint
origins, with radii that are ESTIMATES of a KR-270's link cross-sections.
The markers are taken to face along the flange's x axis (a reflector plate at
the end of the tool, an ASSUMPTION: the cell file gives marker positions, not
orientations).  Both approximations are settings of :class:`DesignSpace`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bayescal.cell.config import Cell
from bayescal.cell.plausible import mass_range_violation
from bayescal.errors import InputError
from bayescal.design.linearisation import solve_equilibrium
from bayescal.robot.batched import BatchedChain, Poses, equilibria
from bayescal.robot.stiffness import EquilibriumError
from bayescal.units import DEG

__all__ = ["DesignSpace", "Feasibility", "load_design_space"]

LINK_RADII = (0.40, 0.30, 0.25, 0.20, 0.15)
"""Radii (m) of the capsules around base→A1, A1→A2, A2→A3, A3→A4 and A4→A5 (ESTIMATES of the
KR-270's castings, which the URDF does not describe); the wrist beyond A5 is left to the incidence test.
For a robot of another number of joints the radii are spread over its nq - 1 segments from the
base to its last but one joint, from the base's radius down to the wrist's (ESTIMATES too)."""

ACCEPTANCE_DEG = 60.0
"""Largest angle (deg) between a marker's facing direction and the line to the tracker: an
ESTIMATE between the ±30° of a hollow-corner cube reflector and the ±60° of a glass-prism one."""

FLOOR_Z = 0.0
"""Height (m) of the floor in the robot's base frame: the robot stands on it."""

HANGING_CLEARANCE = 0.5
"""Height (m) the load point must keep above the floor for the sling and the hanging mass (ESTIMATE)."""

TOOL_CLEARANCE = 0.05
"""Height (m) every other tool point must keep above the floor."""

MIN_ANGLE_SEPARATION_DEG = 5.0
"""Smallest difference (deg) between two of a plan's q2 angles: closer angles add
configurations, not a new point of the compensator's curve."""


@dataclass(frozen=True)
class DesignSpace:
    """The admissible loads and the geometric limits of a campaign, SI.

    Attributes
    ----------
    mass_range : tuple of float
        ``(low, high)`` masses (kg) that may hang at the load point.
    acceptance : float
        Largest incidence angle on a marker, rad.
    link_radii : tuple of float
        Capsule radii of the arm segments (m), see :data:`LINK_RADII`.
    floor_z : float
        Floor height in the base frame, m.
    hanging_clearance, tool_clearance : float
        Clearances above the floor of the load point and of the other tool points, m.
    min_separation : float
        Smallest difference between two q2 angles of a plan, rad.
    source : str
        Where the settings came from.
    """

    mass_range: tuple[float, float]
    acceptance: float = ACCEPTANCE_DEG * DEG
    link_radii: tuple[float, ...] = field(default=LINK_RADII)
    floor_z: float = FLOOR_Z
    hanging_clearance: float = HANGING_CLEARANCE
    tool_clearance: float = TOOL_CLEARANCE
    min_separation: float = MIN_ANGLE_SEPARATION_DEG * DEG
    source: str = "<defaults>"

    def __post_init__(self) -> None:
        reason = mass_range_violation(*self.mass_range)
        if reason is not None:
            raise InputError(reason, source=self.source, column="mass_kg")


def load_design_space(cell: Cell, *, mass_range: tuple[float, float] | None = None) -> DesignSpace:
    """The design space of ``cell``: its file's ``[design]`` table (:class:`~bayescal.cell.config.DesignLimits`), else the defaults.

    The mass range defaults to the cell's ``[load] mass_kg`` alone; ``mass_range``
    (kg), e.g. from the command line, overrides the file.

    Raises
    ------
    InputError
        For an empty or non-positive ``mass_range``.
    """
    limits = cell.design
    source = cell.source
    masses = limits.mass_range or (cell.load_mass, cell.load_mass)
    if mass_range is not None:
        masses, source = mass_range, "mass_range"
    return DesignSpace(
        mass_range=(float(masses[0]), float(masses[1])),
        acceptance=ACCEPTANCE_DEG * DEG if limits.acceptance is None else limits.acceptance,
        floor_z=FLOOR_Z if limits.floor_z is None else limits.floor_z,
        hanging_clearance=HANGING_CLEARANCE if limits.hanging_clearance is None else limits.hanging_clearance,
        source=source,
    )


def _segment_distance(p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Shortest distances (m) between segments ``p0 p1`` ``(..., 3)`` and segments ``a b`` ``(..., 3)`` (closest points
    clamped; the arguments broadcast, the result has their shape without the last axis)."""
    u = p1 - p0
    v = b - a
    w = p0 - a
    uu = np.einsum("...i,...i->...", u, u)
    uv = np.einsum("...i,...i->...", v, u)
    vv = np.einsum("...i,...i->...", v, v)
    uw = np.einsum("...i,...i->...", w, u)
    vw = np.einsum("...i,...i->...", v, w)
    denominator = uu * vv - uv**2
    parallel = denominator < 1e-12 * uu * np.maximum(vv, 1e-300)
    s = np.where(parallel, 0.0, (uv * vw - vv * uw) / np.where(parallel, 1.0, denominator))
    s = np.clip(s, 0.0, 1.0)
    t = np.clip((uv * s + vw) / np.maximum(vv, 1e-300), 0.0, 1.0)
    # Re-clamping s for the clamped t gives the exact closest pair of two segments.
    s = np.clip((t * uv - uw) / uu, 0.0, 1.0)
    gap = w + s[..., np.newaxis] * u - t[..., np.newaxis] * v
    return np.linalg.norm(gap, axis=-1)


class Feasibility:
    """Checks configurations of ``cell`` against ``space``.

    Parameters
    ----------
    cell
        The cell: robot, tool, tracker, compensator.
    space
        The admissible loads and geometric limits.
    """

    def __init__(self, cell: Cell, space: DesignSpace) -> None:
        self.cell = cell
        self.space = space
        self._markers = np.array(list(cell.markers.values()))
        self._tool = np.vstack([np.zeros(3), self._markers])
        segments = cell.robot.nq - 1
        radii = np.asarray(space.link_radii, dtype=float)
        if radii.size != segments and tuple(space.link_radii) == LINK_RADII and segments >= 1:
            radii = np.interp(np.linspace(0.0, radii.size - 1.0, segments), np.arange(radii.size), radii)
        elif radii.size != segments:
            raise InputError(
                f"the visibility model needs {segments} link radii for a {cell.robot.nq}-joint arm, got {radii.size}", source=space.source
            )
        self._radii = radii
        self._chain = BatchedChain.of(cell.robot)

    def violation(self, q, mass: float) -> str | None:
        """Why ``q`` loaded with ``mass`` kg is infeasible, or None when it is feasible.

        The checks run from the cheapest to the equilibrium solve, and the first
        that fails is reported.
        """
        q = np.asarray(q, dtype=float)
        low, high = self.space.mass_range
        if not low - 1e-9 <= mass <= high + 1e-9 and self._within_limits(q) is None:
            return f"load {mass:g} kg outside the mass range {low:g} to {high:g} kg"
        return self.violation_under(q, [0.0, 0.0, -mass * self.cell.gravity])

    def _outside(self, q: np.ndarray) -> np.ndarray:
        """Which joints of configurations ``q`` ``(..., nq)`` are beyond their limits (bool, the same shape)."""
        robot = self.cell.robot
        return (q < robot.lower - 1e-9) | (q > robot.upper + 1e-9)

    def _within_limits(self, q: np.ndarray) -> str | None:
        outside = self._outside(q)
        if outside.any():
            j = int(np.flatnonzero(outside)[0])
            return f"joint {self.cell.robot.joint_names[j]} at {math.degrees(q[j]):.2f} deg is outside its limits"
        return None

    def violation_under(self, q, force, couple=None) -> str | None:
        """Why ``q`` loaded with ``force`` (3,) N through the load point and ``couple`` (3,) N·m (base axes) is infeasible, or None.

        The mass range is not checked here (:meth:`violation` does for a hanging mass);
        the end-effector's limits (``cell.loading``) are.
        """
        couple = np.zeros(3) if couple is None else couple
        q, force, couple = (np.asarray(v, dtype=float)[np.newaxis] for v in (q, force, couple))
        return self.violations_under(q, force, couple)[0]

    def violations_under(self, q: np.ndarray, force: np.ndarray, couple: np.ndarray, *, solve: bool = True,
                         poses: Poses | None = None) -> list[str | None]:
        """:meth:`violation_under` of ``N`` configurations ``(N, nq)`` under forces and couples ``(N, 3)`` (N, N·m), at once.

        The checks run from the cheapest to the equilibrium solve, each on the
        configurations that passed the ones before, and the first that fails is reported.
        ``solve=False`` leaves the equilibrium out, for a caller that solves it anyway;
        ``poses``: the frames of ``q`` (:meth:`BatchedChain.poses <bayescal.robot.batched.BatchedChain.poses>`), when
        the caller has them.
        """
        q, force, couple = (np.asarray(v, dtype=float) for v in (q, force, couple))
        reasons: list[str | None] = [None] * len(q)
        loads = np.concatenate([force, couple], axis=1)
        unique, which = np.unique(loads, axis=0, return_inverse=True)
        load_reasons = [self.cell.loading.force_violation(u[:3]) or self.cell.loading.couple_violation(u[3:]) for u in unique]
        outside = self._outside(q).any(axis=1)
        for i, w in enumerate(which.ravel()):
            reasons[i] = (self._within_limits(q[i]) if outside[i] else None) or load_reasons[w]
        alive = np.array([reason is None for reason in reasons], dtype=bool)
        rows = np.flatnonzero(alive)
        if not rows.size:
            return reasons
        poses = self._chain.poses(q[rows]) if poses is None else poses.take(rows)
        markers = np.stack([poses.points(point) for point in self._markers], axis=1)
        floor = self.space.floor_z
        low_tool = (poses.flange_origin[:, 2] < floor + self.space.tool_clearance) | np.any(markers[:, :, 2] < floor + self.space.tool_clearance, axis=1)
        low_load = poses.points(self.cell.load_point)[:, 2] < floor + self.space.hanging_clearance
        for k, row in enumerate(rows):
            if low_tool[k]:
                reasons[row] = "a tool point is below the floor"
            elif low_load[k]:
                reasons[row] = "the hanging load would touch the floor"
        keep = ~(low_tool | low_load)
        for k, reason in zip(np.flatnonzero(keep), self._visibility(poses, markers, keep)):
            reasons[rows[k]] = reason
        keep &= np.array([reasons[row] is None for row in rows], dtype=bool)
        if solve:
            self._equilibria(q[rows[keep]], force[rows[keep]], couple[rows[keep]], rows[keep], reasons)
        return reasons

    def equilibrium_violations(self, q: np.ndarray, force: np.ndarray, couple: np.ndarray) -> list[str | None]:
        """Why each of ``N`` configurations ``(N, nq)`` under forces and couples ``(N, 3)`` has no loaded equilibrium (None
        where it has one): :meth:`violations_under`'s last check alone, for a caller that ran the others with ``solve=False``
        and gathers the configurations that passed them into one solve."""
        q, force, couple = (np.asarray(v, dtype=float) for v in (q, force, couple))
        reasons: list[str | None] = [None] * len(q)
        self._equilibria(q, force, couple, np.arange(len(q)), reasons)
        return reasons

    def _equilibria(self, q: np.ndarray, force: np.ndarray, couple: np.ndarray, rows: np.ndarray, reasons: list) -> None:
        """Mark the ``rows`` whose loaded equilibrium does not exist; all are solved together, one by one only when one fails."""
        if not len(q):
            return
        cell = self.cell
        rotation = self._chain.poses(q).flange_rotation
        wrench = np.concatenate([force, np.cross(np.einsum("nij,j->ni", rotation, cell.load_point), force) + couple], axis=1)
        try:
            equilibria(self._chain, q, wrench, cell.compliances, compensator=cell.compensator, compensated_joint=cell.compensated_joint, load_point=cell.load_point)
            return
        except EquilibriumError:
            pass
        for qi, w, row in zip(q, wrench, rows):
            try:
                solve_equilibrium(cell, qi, w, cell.load_point)
            except EquilibriumError as exc:
                reasons[row] = f"no loaded equilibrium ({exc})"

    def _visibility(self, poses, markers: np.ndarray, rows: np.ndarray) -> list[str | None]:
        """Why each configuration of ``poses`` selected by the bool ``rows`` cannot see every marker (positions ``markers`` (N, m, 3))."""
        tracker = self.cell.tracker.position
        facing = poses.flange_rotation[rows][:, :, 0]
        markers = markers[rows]
        sight = tracker - markers
        cosine = np.einsum("nmi,ni->nm", sight, facing) / np.linalg.norm(sight, axis=2)
        worst = np.argmin(cosine, axis=1)
        joints = poses.origins[rows]
        start = np.concatenate([np.stack([joints[:, 0, 0], joints[:, 0, 1], np.full(len(joints), self.space.floor_z)], axis=1)[:, None], joints[:, :-2]], axis=1)
        end = joints[:, :-1]
        hidden = _segment_distance(tracker, markers[:, :, None, :], start[:, None], end[:, None]) < self._radii
        names = list(self.cell.markers)
        # the tests on whole arrays, the texts for the configurations that fail alone (most of a search's draws)
        facing = cosine[np.arange(len(markers)), worst]
        away = facing < math.cos(self.space.acceptance)
        hidden = hidden.any(axis=2)
        reasons: list[str | None] = [None] * len(markers)
        # the angles of every configuration turned away at once: a search's draws are mostly turned away
        rows_away = np.flatnonzero(away)
        angles = np.degrees(np.arccos(np.clip(facing[rows_away], -1.0, 1.0))).tolist()
        for n, angle in zip(rows_away.tolist(), angles):
            reasons[n] = f"marker {names[worst[n]]} faces {angle:.0f} deg away from the tracker"
        for n in np.flatnonzero(~away & hidden.any(axis=1)).tolist():
            reasons[n] = f"the arm hides marker {names[int(np.argmax(hidden[n]))]} from the tracker"
        return reasons
