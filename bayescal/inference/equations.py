"""The scalar equations of a campaign (eq 30) and the checks a campaign must pass.

Klimchik et al., section V.B.  Each measured coordinate of a marker's
deflection gives one equation, linear in the joint compliances:
``Δp = A k`` with ``A`` the matrix of eq 31 for the marker.  The equations
carry each row's q2 angle (for the per-angle joint-2 compliances of eq 33)
and its noise group.  Markers are located on the tool by their measured
unloaded positions, so a campaign needs no description of the tool.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.campaign_checks import check_force_columns
from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.cell.config import DEFAULT_COMPENSATED_JOINT
from bayescal.inference.parameters import ANGLE_DECIMALS, ParameterRegistry
from bayescal.robot.batched import CHUNK, BatchedChain
from bayescal.robot.compensator import Compensator
from bayescal.robot.kinematics import Robot
from bayescal.units import DEG, MM

__all__ = [
    "DeflectionEquations", "deflection_equations", "deflection_noise", "check_campaign", "check_load_point", "COUPLE_TOLERANCE",
    "group_angles", "MAX_ANGLES", "MAX_DEFLECTION", "MAX_MARKER_DISTANCE", "MARKER_TOLERANCE",
]

MAX_DEFLECTION = 50 * MM
"""Largest marker deflection accepted: far beyond what a loaded industrial robot shows."""
MAX_MARKER_DISTANCE = 2.0
"""Largest distance (m) of a marker from the flange origin: a tool is smaller than this."""
MARKER_TOLERANCE = 10 * MM
"""How far a marker's position on the tool may scatter between rows once each configuration's
tool is turned onto the others (:func:`_unsagged`): the markers' noise and the tool's own
deflection, a fraction of a mm; a swapped label moves a marker by the markers' spacing."""
SAG_ROTATION = 0.1
"""Largest rotation (rad, 5.7 deg) of a configuration's whole tool taken as the arm's sag.

A heavy arm with a spring far stiffer than its weight needs sags by degrees before any
load (the twin's KR-270 with a spring 20 times the cell's: 1.7 deg), which moves every
marker by tens of mm in the flange frame computed at the commanded joints; a swap of two
labels on a symmetric tool is a half turn, far beyond it."""
COUPLE_TOLERANCE = 5.0
"""Largest difference (N·m) between a wrench's couple and its force's moment at the load point taken as
rounding: the moment of the KR-270's 2,650 N rated load over 2 mm of load point."""
MAX_ANGLES = 16
"""Most distinct q2 angles kept apart.  The paper's device of one joint-2 compliance per angle
(eq 33) suits a handful of angles; a campaign whose q2 varies freely has its rows grouped into
this many bins of about equal count instead, each one angle at the mean q2 of its rows.  With
the KR-270 cell's spring the compensator's share of the joint-2 stiffness changes by at most
0.005 % per degree of q2, so a bin about 10° wide blurs it by a few hundredths of a percent,
well below what per-angle compliances resolve."""

@dataclass(frozen=True)
class DeflectionEquations:
    """The scalar equations of a campaign, linear in the joint compliances.

    Parameters
    ----------
    y
        Measured deflection components (m), shape ``(n,)``.
    design
        ``(n, nq)``: column j is the deflection per unit compliance of joint j
        (m per rad/(N·m)).
    angle
        ``(n,)`` index into ``compensated_angles`` of each equation's compensated-joint angle (zeros without a compensator).
    compensated_angles
        The distinct angles (rad) of the compensated joint (``q2`` on the KR-270), shape ``(m,)``; ``(0,)``
        without a compensator.
    group
        ``(n,)`` noise group of each equation (index into ``group_names``).
    group_names
        Names of the noise groups, e.g. ``("x", "y", "z")``.
    scale
        ``(n,)`` known relative noise sd of each equation (e.g. from the
        tracker's distance-dependent error); the group's unknown sigma
        multiplies it.  None: all equal.
    joint, law
        Index (0-based) of the joint whose compliance is taken per angle (the cell's
        compensated joint); ``angle`` and ``compensated_angles`` are that joint's.  None: the robot has no
        compensator and every joint has one constant compliance.  ``law``: its law's identified parameters.
    prismatic
        Which joints are prismatic (their compliances in m/N); empty: all revolute.
    """

    y: np.ndarray
    design: np.ndarray
    angle: np.ndarray
    compensated_angles: np.ndarray
    group: np.ndarray
    group_names: tuple[str, ...]
    scale: np.ndarray | None = None
    joint: int | None = DEFAULT_COMPENSATED_JOINT
    prismatic: tuple[bool, ...] = ()
    law: tuple = Compensator.PARAMETERS

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        if self.design.ndim != 2 or self.design.shape[0] != n or self.angle.shape != (n,) or self.group.shape != (n,):
            raise ValueError("y, design, angle and group must describe the same equations")
        angles = self.compensated_angles.size if self.joint is not None else 1
        if self.angle.max(initial=0) >= angles or self.group.max(initial=0) >= len(self.group_names):
            raise ValueError("angle or group index out of range")

    def whitened(self) -> DeflectionEquations:
        """The same equations divided by their relative noise sd, so that noise is equal within a group."""
        if self.scale is None:
            return self
        return replace(self, y=self.y / self.scale, design=self.design / self.scale[:, None], scale=None)

    @property
    def registry(self) -> ParameterRegistry:
        """The parameters these equations identify: names, edge units and SI factors."""
        return ParameterRegistry(self.n_joints, self.prismatic, self.joint, law=self.law)

    @property
    def n_joints(self) -> int:
        """Number of joints (columns of ``design``)."""
        return int(self.design.shape[1])

    @property
    def n(self) -> int:
        """Number of scalar equations."""
        return int(self.y.shape[0])

    def per_angle_columns(self) -> list[tuple[int, int | None]]:
        """``(joint, angle)`` of each per-angle column: the compensated joint once per angle, the others once."""
        columns: list[tuple[int, int | None]] = []
        for joint in range(self.n_joints):
            if joint == self.joint:
                columns.extend((joint, a) for a in range(self.compensated_angles.size))
            else:
                columns.append((joint, None))
        return columns

    def per_angle_design(self, keep: np.ndarray | None = None) -> np.ndarray:
        """The design of eq 30 with one compensated-joint column per distinct angle, ``(n, nq - 1 + m)``
        (``(n, nq)`` without a compensator); ``keep``, a boolean mask of those columns, selects some.

        Written column by column into one array: a large campaign's design is hundreds of MB.
        """
        columns = self.per_angle_columns()
        chosen = [c for c, kept in zip(columns, np.ones(len(columns), bool) if keep is None else keep) if kept]
        design = np.zeros((self.n, len(chosen)))
        for i, (joint, angle) in enumerate(chosen):
            if angle is None:
                design[:, i] = self.design[:, joint]
            else:
                rows = self.angle == angle
                design[rows, i] = self.design[rows, joint]
        return design


def deflection_equations(
    robot: Robot,
    campaign: Campaign,
    *,
    noise: str = "axis",
    tracker: TrackerNoise | None = None,
    joint: int | None = DEFAULT_COMPENSATED_JOINT,
    law: tuple = Compensator.PARAMETERS,
) -> tuple[DeflectionEquations, np.ndarray, np.ndarray]:
    """The scalar equations of eq 30 for a campaign, with the loads' joint torques.

    Parameters
    ----------
    robot
        The robot.
    campaign
        The measurements.
    noise
        ``"axis"``: one noise level per base-frame axis; ``"marker"``: one per marker.
    tracker
        When given, each equation's noise is taken proportional to the tracker's
        error at the unloaded and loaded positions, ``sqrt(s(p0)^2 + s(p1)^2)``
        (scaled to mean 1; the unknown level per group multiplies it).
    joint, law
        Index (0-based) of the joint whose compliance is taken per angle: the cell's compensated joint;
        None without a compensator (every compliance constant).  ``law``: its law's identified parameters.

    Returns
    -------
    equations : DeflectionEquations
        Three equations per campaign row (x, y, z of the deflection).
    torque : numpy.ndarray
        ``(N, nq)`` joint torques ``J_F' w`` of each row's load (N·m).
    points : numpy.ndarray
        ``(N, 3)`` markers in the flange frame (m), from the unloaded positions.
    """
    n = len(campaign)
    design, torque, points = _designs(robot, campaign)
    if joint is None:
        values, angle = np.empty(0), np.zeros(n, dtype=int)
    else:
        values, angle = group_angles(campaign.q[:, joint])
    group, names = _noise_groups(campaign, noise)
    equations = DeflectionEquations(
        y=campaign.displacement.reshape(-1),
        design=design.reshape(-1, robot.nq),
        angle=np.repeat(angle, 3),
        compensated_angles=values,
        group=group,
        group_names=names,
        scale=None if tracker is None else np.repeat(_relative_noise(tracker, campaign), 3),
        joint=joint,
        prismatic=tuple(bool(p) for p in robot.prismatic) if robot.prismatic.any() else (),
        law=law,
    )
    return equations, torque, points


def _designs(robot: Robot, campaign: Campaign) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq 31's design ``(N, 3, nq)``, the loads' joint torques ``(N, nq)`` N·m and the markers in the flange frame ``(N, 3)`` m."""
    n = len(campaign)
    design, torque, points = np.empty((n, 3, robot.nq)), np.empty((n, robot.nq)), np.empty((n, 3))
    chain = BatchedChain.of(robot)
    # Rows by chunks of the batched chain (a loop of Pinocchio calls cost ~45 μs a row; all rows at once held
    # 450 MB of joint frames at 100,000 configurations).
    for start in range(0, n, CHUNK):
        rows = slice(start, start + CHUNK)
        poses = chain.poses(campaign.q[rows])
        points[rows] = poses.in_flange(campaign.p0[rows])
        flange_linear, angular = chain.point_jacobian(poses, poses.flange_origin)
        wrench = campaign.wrench[rows]
        torque[rows] = np.einsum("njd,nd->nj", flange_linear, wrench[:, :3]) + np.einsum("njd,nd->nj", angular, wrench[:, 3:])
        # Eq 31: column j of a marker's design is its Jacobian's column j times the load's torque on joint j.
        design[rows] = np.swapaxes(chain.point_jacobian(poses, campaign.p0[rows])[0], 1, 2) * torque[rows, None, :]
    return design, torque, points


def _noise_groups(campaign: Campaign, noise: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """Each equation's noise group ``(3N,)`` and the groups' names: per base axis (``"axis"``) or per marker."""
    n = len(campaign)
    if noise == "axis":
        return np.tile(np.arange(3), n), ("x", "y", "z")
    if noise == "marker":
        names, index = np.unique(campaign.marker.astype(str), return_inverse=True)
        return np.repeat(index, 3), tuple(str(m) for m in names)
    raise ValueError(f"noise must be 'axis' or 'marker', got {noise!r}")


def group_angles(q2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct joint-2 angles of a campaign, grouped into at most :data:`MAX_ANGLES`.

    Parameters
    ----------
    q2
        ``(n,)`` joint-2 angle of each row (rad).

    Returns
    -------
    angles : numpy.ndarray
        ``(m,)`` increasing angles (rad): the distinct angles (rounded to
        :data:`ANGLE_DECIMALS` of a degree), or the mean angle of each bin.
    index : numpy.ndarray
        ``(n,)`` each row's entry in ``angles``.
    """
    degrees = np.round(np.asarray(q2, dtype=float) / DEG, ANGLE_DECIMALS)
    values, index = np.unique(degrees, return_inverse=True)
    if values.size <= MAX_ANGLES:
        return values * DEG, index
    edges = np.quantile(degrees, np.linspace(0.0, 1.0, MAX_ANGLES + 1)[1:-1])
    _, index = np.unique(np.searchsorted(edges, degrees, side="right"), return_inverse=True)
    centres = np.bincount(index, weights=degrees) / np.bincount(index)
    return centres * DEG, index


def deflection_noise(tracker: TrackerNoise, campaign: Campaign) -> np.ndarray:
    """Nominal sd (m) of each coordinate of each row's deflection: the tracker reads p0 and p1 independently,
    plus the variance the campaign's frame adds (:attr:`Campaign.added_variance`, a registration's)."""
    variance = tracker.deflection_variance(campaign.p0, campaign.p1)
    return np.sqrt(variance if campaign.added_variance is None else variance + campaign.added_variance)


def _relative_noise(tracker: TrackerNoise, campaign: Campaign) -> np.ndarray:
    sd = deflection_noise(tracker, campaign)
    return sd / sd.mean()


def check_campaign(robot: Robot, campaign: Campaign, points: np.ndarray, *, hanging_only: bool = False) -> None:
    """Reject deflections, marker positions or forces no robot could produce; warn when all loads are parallel.

    ``hanging_only``: the cell's end-effector can only hang masses, so vertical loads are all it
    can apply: k1's reason records it (:data:`HANGING_ONLY_REASON`) and ``bayescal plan`` says it once.

    Raises
    ------
    InputError
        A deflection above :data:`MAX_DEFLECTION`; a marker farther than
        :data:`MAX_MARKER_DISTANCE` from the flange (naming the slip whose undoing puts
        the markers on the tool, if one does: metres, two axes swapped); a marker label
        off its point of the tool; markers moving across their forces with two force
        columns swapped (:func:`~bayescal.cell.campaign_checks.check_force_columns`).
    """
    _reject_largest(
        campaign,
        campaign.displacement,
        MAX_DEFLECTION,
        "1_mm",
        lambda marker, size: f"marker '{marker}' deflects by {size / MM:.4g} mm under load, more than the "
        f"{MAX_DEFLECTION / MM:.0f} mm a loaded robot can plausibly deflect: are x1_mm..z1_mm in another unit?",
    )
    _reject_largest(
        campaign,
        points,
        MAX_MARKER_DISTANCE,
        "0_mm",
        lambda marker, size: f"marker '{marker}' is {size:.3g} m from the flange, farther than any tool "
        f"({MAX_MARKER_DISTANCE:g} m): {_position_slip(robot, campaign)}",
        columns=campaign.p0,
    )
    _check_markers(campaign, points)
    check_force_columns(campaign.wrench, campaign.displacement, campaign.lines, campaign.source)
    forces = campaign.wrench[:, :3]
    loaded = forces[np.linalg.norm(forces, axis=1) > 0]
    if loaded.shape[0]:
        singular = np.linalg.svd(loaded / np.linalg.norm(loaded, axis=1, keepdims=True), compute_uv=False)
        direction = loaded[0] / np.linalg.norm(loaded[0])
        vertical = abs(direction[2]) > 1.0 - 1e-6
        if (singular.size < 2 or singular[1] < 1e-3 * singular[0]) and not (hanging_only and vertical):
            warnings.warn(
                f"{campaign.source}: all loads are parallel (force direction {np.array2string(direction, precision=3)}); "
                "Klimchik et al. advise varying the load direction: parameters such loads cannot excite are reported as not identifiable",
                UserWarning,
                stacklevel=2,
            )


HANGING_ONLY_REASON = (
    'this cell\'s end-effector hangs masses only ([load] directions = "down"), and a vertical load never turns the '
    "vertical A1, so no campaign of this cell identifies k1 and it keeps the cell's value; a cell that pushes or pulls "
    'sideways (directions = "any", docs/design.md) identifies it'
)
"""Added to k1's not-identifiable reason on a cell that can only hang masses, in place of the parallel-loads warning.
Worded for a plan the tool itself designs: ``bayescal plan`` says it once, and a fit records it without warning."""


def check_load_point(robot: Robot, campaign: Campaign, load_point: np.ndarray | None) -> None:
    """Warn once when a wrench's couple is not the moment of its force at the load point.

    The load point is the campaign's own (its ``load_*_mm`` columns) or else
    ``load_point``.  A hanging mass exerts exactly the force's moment about
    the flange origin; a couple beyond :data:`COUPLE_TOLERANCE` means the load
    acts elsewhere, or the wrench holds a couple of its own.  The exact model
    treats the remainder as a dead couple either way; the warning names the
    largest discrepancy.
    """
    configs = np.unique(campaign.config, return_index=True)[1]
    points = np.zeros((len(campaign), 3)) if load_point is None else np.broadcast_to(load_point, (len(campaign), 3))
    if campaign.load_point is not None:
        points = campaign.load_point
    rotation = BatchedChain.of(robot).poses(campaign.q[configs]).flange_rotation
    force, couple = campaign.wrench[configs, :3], campaign.wrench[configs, 3:]
    discrepancy = np.linalg.norm(couple - np.cross(np.einsum("nij,nj->ni", rotation, points[configs]), force), axis=1)
    worst = int(np.argmax(discrepancy)) if discrepancy.size else 0
    if discrepancy.size and discrepancy[worst] > COUPLE_TOLERANCE:
        line = int(campaign.lines[configs[worst]])
        warnings.warn(
            f"{campaign.source}{f':{line}' if line else ''}: the wrench's couple differs by {discrepancy[worst]:.3g} N·m "
            "from the moment of its force at the load point "
            f"({'the campaign' if campaign.load_point is not None else 'the cell'}'s); the difference is taken as a dead couple",
            UserWarning,
            stacklevel=3,
        )


def _reject_largest(campaign: Campaign, vectors: np.ndarray, limit: float, suffix: str, message, columns=None) -> None:
    """Raise an InputError naming the row whose vector is longest when it exceeds ``limit``.

    The column named is the coordinate (``x``, ``y`` or ``z`` followed by ``suffix``)
    of ``columns`` (default ``vectors``) largest in that row.
    """
    size = np.linalg.norm(vectors, axis=1)
    worst = int(np.argmax(size))
    if size[worst] > limit:
        values = vectors if columns is None else columns
        raise InputError(
            message(campaign.marker[worst], size[worst]),
            source=campaign.source,
            line=int(campaign.lines[worst]) or None,
            column="xyz"[int(np.argmax(np.abs(values[worst])))] + suffix,
        )


_POSITION_SLIPS = (
    ("read in mm", "are x0_mm..z1_mm in metres instead of mm?", lambda p: p / MM),
    ("with x and y exchanged", "are x and y swapped (x0_mm with y0_mm, x1_mm with y1_mm), a mirrored frame?", lambda p: p[:, [1, 0, 2]]),
    ("with x and z exchanged", "are x and z swapped (x0_mm with z0_mm, x1_mm with z1_mm), a mirrored frame?", lambda p: p[:, [2, 1, 0]]),
    ("with y and z exchanged", "are y and z swapped (y0_mm with z0_mm, y1_mm with z1_mm), a mirrored frame?", lambda p: p[:, [0, 2, 1]]),
)
"""The slips a campaign's positions may have suffered: how each is undone, and the question that names it."""


def _position_slip(robot: Robot, campaign: Campaign) -> str:
    """The question naming the slip whose undoing puts every marker on one point of the tool, or what else to check.

    A slip is named only when the data support it: undone, every marker lies within
    :data:`MAX_MARKER_DISTANCE` of the flange and on one point of the tool in every
    row, to :data:`MARKER_TOLERANCE` once each configuration's sag is turned out
    (:func:`_unsagged`).  A campaign in metres or with two axes swapped puts its
    markers metres apart from row to row; undone, they agree to the sag's mm.
    """
    chain = BatchedChain.of(robot)
    labels = np.asarray(campaign.marker).astype(str)
    for reading, question, undo in _POSITION_SLIPS:
        fixed = undo(campaign.p0)
        points = np.empty_like(fixed)
        for start in range(0, len(campaign), CHUNK):
            rows = slice(start, start + CHUNK)
            points[rows] = chain.poses(campaign.q[rows]).in_flange(fixed[rows])
        if np.linalg.norm(points, axis=1).max() > MAX_MARKER_DISTANCE:
            continue
        aligned = _unsagged(campaign, points)
        scatter = max(float(np.linalg.norm(aligned[labels == label] - np.median(aligned[labels == label], axis=0), axis=1).max())
                      for label in np.unique(labels))
        if scatter <= MARKER_TOLERANCE:
            return f"{reading}, every marker sits on one point of the tool (to {scatter / MM:.1f} mm): {question}"
    return ("neither a unit slip nor an exchange of two axes puts the markers on one point of the tool: are x0_mm..z1_mm "
            "in the robot's base frame?")


def _unsagged(campaign: Campaign, points: np.ndarray) -> np.ndarray:
    """(N, 3) the rows' flange-frame marker points with each configuration's sag turned out.

    The points come from the unloaded readings at the commanded joints, so the arm's
    sag moves all markers of a configuration together, as one rigid motion of the
    tool.  Each configuration with three or more markers is turned and shifted onto
    the markers' median places (the least-squares rigid fit), when that motion is a
    turn of at most :data:`SAG_ROTATION`; other configurations are left as they are.
    """
    names, label = np.unique(np.asarray(campaign.marker).astype(str), return_inverse=True)
    median = np.array([np.median(points[label == i], axis=0) for i in range(names.size)])
    # Every configuration at once: (configuration, marker) cells hold the mean of their rows' points.
    configs, config = np.unique(campaign.config, return_inverse=True)
    cell = config * names.size + label
    counts = np.bincount(cell, minlength=configs.size * names.size).reshape(configs.size, names.size)
    sums = np.stack([np.bincount(cell, points[:, d], configs.size * names.size) for d in range(3)], axis=-1)
    seen = counts > 0
    mine = sums.reshape(configs.size, names.size, 3) / np.maximum(counts, 1)[..., None]
    n_seen = np.maximum(seen.sum(axis=1), 1)[:, None]
    mine_mean = np.sum(np.where(seen[..., None], mine, 0.0), axis=1) / n_seen
    target_mean = seen.astype(float) @ median / n_seen
    mine_c = np.where(seen[..., None], mine - mine_mean[:, None], 0.0)
    target_c = np.where(seen[..., None], median[None] - target_mean[:, None], 0.0)
    u, _, vt = np.linalg.svd(np.swapaxes(mine_c, 1, 2) @ target_c)
    flip = np.ones((configs.size, 3))
    flip[:, 2] = np.sign(np.linalg.det(u @ vt))
    rotation = np.swapaxes((u * flip[:, None, :]) @ vt, 1, 2)
    turn = np.arccos(np.clip((np.trace(rotation, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    moved = (seen.sum(axis=1) >= 3) & (turn <= SAG_ROTATION)
    rows = moved[config]
    aligned = np.array(points, dtype=float)
    shifted = points[rows] - mine_mean[config[rows]]
    aligned[rows] = np.einsum("nij,nj->ni", rotation[config[rows]], shifted) + target_mean[config[rows]]
    return aligned


def _check_markers(campaign: Campaign, points: np.ndarray) -> None:
    """Each marker label must name one point of the tool, measured in several configurations.

    A marker is rigid on the tool, so its flange-frame position, recovered from
    each row's unloaded reading, is the same in every row up to the arm's sag.
    A label seen in a single configuration, or a row far from where its label
    sits in the other rows, is a typo or a swapped label, which would silently
    bias the compliances.
    """
    labels = sorted(set(campaign.marker))
    aligned = _unsagged(campaign, points)
    configurations = {label: np.unique(campaign.config[campaign.marker == label]) for label in labels}
    repeated = [label for label in labels if configurations[label].size >= 2]
    for label in labels:
        rows = np.flatnonzero(campaign.marker == label)
        # A label seen once is only suspicious beside labels that are measured in several configurations.
        if configurations[label].size < 2 and repeated:
            raise InputError(
                f"unknown marker '{label}': it is measured in configuration {configurations[label][0]} only, while "
                f"{', '.join(repeated)} are measured in several; a marker must be measured in at least two configurations",
                source=campaign.source,
                line=int(campaign.lines[rows[0]]) or None,
                column="marker",
            )
        centre = np.median(aligned[rows], axis=0)
        offset = np.linalg.norm(aligned[rows] - centre, axis=1)
        worst = int(np.argmax(offset))
        if offset[worst] > MARKER_TOLERANCE:
            raise InputError(
                f"marker '{label}' is {offset[worst] / MM:.1f} mm from where '{label}' sits on the tool in its other "
                f"rows (more than {MARKER_TOLERANCE / MM:.0f} mm): a mislabelled marker?",
                source=campaign.source,
                line=int(campaign.lines[rows[worst]]) or None,
                column="marker",
            )


