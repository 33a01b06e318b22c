"""What the critique knows about every measured deflection: kinematics, torques and the covariates a user would suspect.

A campaign row is one marker, read unloaded and loaded in one repeat of one
configuration; its deflection gives three scalar equations (x, y, z in the
base axes).  :class:`Rows` holds, per row, what the models of
:mod:`bayescal.critique.extensions` are built from (the marker's Jacobian,
the joint torques of the load, of the arm's weight and of the compensator,
the joint frames) and the covariates residuals are checked against
(:data:`COVARIATES`).  Everything is evaluated at the arm's measured
unloaded pose (:func:`measured_pose`), about which the linear model of eq 30
holds, with the load's wrench referred to that pose (:func:`wrench_at_pose`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.robot.stiffness import ElasticArm, EquilibriumError

__all__ = ["Rows", "PREDICTED_MARKER", "REVERSED_MARKER", "campaign_rows", "pose_rows", "measured_pose", "predicted_pose", "wrench_at_pose", "COVARIATES"]

POSE_MIN_MARKERS = 3
"""Markers needed to fix the tool's pose (position and orientation)."""
POSE_ITERATIONS = 10
POSE_TOLERANCE = 1e-10
"""Gauss-Newton on the pose stops when no joint moves by more than this, rad."""
POSE_SHAPE_FACTOR = 2.0
"""Largest median rms distance between the markers placed as the cell file says and their readings,
in tracker noise sds (the cell's per-coordinate sd at the readings).

With the markers where the file says, the misfit left after fitting a pose (6 unknowns)
to three markers' mean readings (9 coordinates, three repeats each) is about 0.3 sd
(measured on the twin: 12 μm against 38 μm).  Beyond 2 sd the file's places are off by
more than the tracker explains, and a pose fitted to them would turn by up to their error
over the markers' spacing (3 mm over 115 mm: 26 mrad)."""
POSE_MAX_SAG = 0.15
"""Largest sag (rad, about 9 deg) accepted between commanded and measured pose; beyond it the
markers are not where the cell file puts them and the commanded pose is used."""

PREDICTED_MARKER = "test"
"""The marker name of rows built for a prediction (:func:`pose_rows`): poses not measured in sequence."""
REVERSED_MARKER = "test after reversal"
"""The marker name of rows built for a plan's first loading of a configuration measured right after a load that
took the plan joint to the other side of its play (:mod:`bayescal.design.discriminate` orders its plans so)."""

COVARIATES = {
    "q2": "the joint-2 angle",
    "other joints": "the joint angles q1, q3..q6",
    "torques": "the joint torques of the load",
    "torque signs": "the signs of the joint torques under load",
    "load": "the load's force (magnitude and direction)",
    "reach": "the marker's distance from the base axis",
    "marker": "which marker",
    "lever": "the marker's position on the tool",
    "tracker distance": "the marker's distance to the tracker",
    "order": "the order of measurement",
}
"""The covariates a misfit is checked against, with what they mean."""


@dataclass(frozen=True, eq=False)
class Rows:
    """Per-row kinematics and covariates (SI, base axes), N rows.

    Attributes
    ----------
    y : numpy.ndarray
        (N, 3) measured deflections, m (zeros for a pose to predict).
    q : numpy.ndarray
        (N, nq) joint angles of the links unloaded (the measured pose), rad.
    wrench : numpy.ndarray
        (N, 6) load at the flange origin with the tool at ``q``, N and N·m.
    point : numpy.ndarray
        (N, 3) the marker in the flange frame, m.
    position : numpy.ndarray
        (N, 3) the marker unloaded, base frame, m.
    point_jacobian : numpy.ndarray
        (N, 3, nq) the marker's position Jacobian.
    load_torque : numpy.ndarray
        (N, nq) joint torques of the load ``J_F' w``, N·m.
    static_torque : numpy.ndarray
        (N, nq) torques the joint springs carry unloaded (the arm's weight and the
        compensator's moment), N·m; loaded they carry ``static_torque + load_torque``.
    frames : numpy.ndarray
        (N, nq, 4, 4) placements of the joint frames in the base frame.
    flange : numpy.ndarray
        (N, 4, 4) placement of the flange frame.
    config, repeat, order : numpy.ndarray of int
        (N,) configuration, repeat and position in the measurement sequence.
    marker : numpy.ndarray of str
        (N,) marker names.
    noise : numpy.ndarray
        (N,) relative noise of each row's deflection (mean 1): the tracker's error at
        the unloaded and loaded positions.
    tracker_distance : numpy.ndarray
        (N,) distance of the marker from the tracker, m.
    commanded : numpy.ndarray
        (N, nq) the controller's joint angles (rad or m) the arm was driven to; ``q`` is the
        pose it took under its weight.
    times : numpy.ndarray
        (N, 2) when the unloaded and the loaded reading were taken, s (the campaign's
        ``t0_s, t1_s``); NaN where the campaign gives no times, and for poses to predict.
    plan_joint : int
        Index (0-based) of the joint whose angles group the campaign (the cell's :attr:`~bayescal.cell.config.Cell.plan_joint`).
    """

    y: np.ndarray
    q: np.ndarray
    wrench: np.ndarray
    point: np.ndarray
    position: np.ndarray
    point_jacobian: np.ndarray
    load_torque: np.ndarray
    static_torque: np.ndarray
    frames: np.ndarray
    flange: np.ndarray
    config: np.ndarray
    repeat: np.ndarray
    order: np.ndarray
    marker: np.ndarray
    noise: np.ndarray
    tracker_distance: np.ndarray
    commanded: np.ndarray
    times: np.ndarray
    plan_joint: int

    def __len__(self) -> int:
        return len(self.y)

    @property
    def design(self) -> np.ndarray:
        """(N, 3, nq) eq 31 for every row: column ``j`` is the marker's displacement per unit compliance of joint ``j``."""
        return self.point_jacobian * self.load_torque[:, np.newaxis, :]

    def take(self, index: np.ndarray) -> Rows:
        """The rows ``index``."""
        rows = {name: getattr(self, name)[index] for name in self.__dataclass_fields__ if name != "plan_joint"}
        return Rows(**rows, plan_joint=self.plan_joint)

    def extend(self, other: Rows) -> Rows:
        """These rows followed by ``other``'s."""
        if other.plan_joint != self.plan_joint:
            raise ValueError("rows of cells with different plan joints cannot be joined")
        fields = [name for name in self.__dataclass_fields__ if name != "plan_joint"]
        return Rows(**{name: np.concatenate([getattr(self, name), getattr(other, name)]) for name in fields}, plan_joint=self.plan_joint)


def _static_torque(cell: Cell, q: np.ndarray, workspace) -> np.ndarray:
    """Torque the joint springs carry with the arm unloaded at ``q``: minus gravity minus the compensator's moment
    (computed in ``workspace``, one of ``cell.robot``'s)."""
    torque = -workspace.gravity_torque(q)
    if cell.compensator is not None:
        torque[cell.compensated_joint] -= cell.compensator.torque(float(q[cell.compensated_joint]))
    return torque


def _build(cell: Cell, q, wrench, point, position, y, config, repeat, marker, noise, times=None, commanded=None) -> Rows:
    robot = cell.robot
    n, nq = q.shape
    jacobian = np.empty((n, 3, nq))
    load_torque = np.empty((n, nq))
    static = np.empty((n, nq))
    frames = np.empty((n, nq, 4, 4))
    flange = np.empty((n, 4, 4))
    data = robot.model.createData()
    # one workspace for the loop's other kinematic calls: creating one per call cost as much as the calls
    workspace = robot.workspace()
    cache: dict[bytes, tuple] = {}
    for i in range(n):
        key = q[i].tobytes() + wrench[i].tobytes()
        if key not in cache:
            pin.forwardKinematics(robot.model, data, q[i])
            rotation, origin = workspace.flange_pose(q[i])
            cache[key] = (
                workspace.flange_jacobian(q[i]).T @ wrench[i],
                _static_torque(cell, q[i], workspace),
                np.array([data.oMi[j + 1].homogeneous for j in range(nq)]),
                np.block([[rotation, origin[:, np.newaxis]], [np.zeros((1, 3)), np.ones((1, 1))]]),
            )
        load_torque[i], static[i], frames[i], flange[i] = cache[key]
        jacobian[i] = workspace.point_jacobian(q[i], point[i])
    # Order of measurement: configurations as first met in the file, then repeats.
    first = {c: k for k, c in enumerate(dict.fromkeys(config.tolist()))}
    order = np.array([first[c] for c in config.tolist()]) * (int(repeat.max()) + 1) + repeat
    return Rows(
        y=y,
        q=q,
        wrench=wrench,
        point=point,
        position=position,
        point_jacobian=jacobian,
        load_torque=load_torque,
        static_torque=static,
        frames=frames,
        flange=flange,
        config=config,
        repeat=repeat,
        order=np.unique(order, return_inverse=True)[1],
        marker=marker,
        noise=noise,
        tracker_distance=np.linalg.norm(position - cell.tracker.position, axis=1),
        commanded=q.copy() if commanded is None else np.asarray(commanded, dtype=float),
        times=np.full((n, 2), np.nan) if times is None else np.asarray(times, dtype=float),
        plan_joint=cell.plan_joint,
    )


def measured_pose(cell: Cell, q, points: np.ndarray, positions: np.ndarray) -> tuple[np.ndarray, float]:
    """Link angles (rad) that put the tool ``points`` at their unloaded ``positions``, from the commanded ``q``.

    The arm sags under its weight and the compensator's moment before any load is
    applied; the linear model of eq 30 is accurate about the pose the arm is
    actually in, which three or more markers at known places on the tool fix.
    Gauss-Newton, started at ``q``.

    Parameters
    ----------
    points
        (k, 3) the markers' places on the tool, flange frame, m.
    positions
        (k, 3) their unloaded readings, m.

    Returns
    -------
    tuple
        The link angles (``q`` itself when fewer than three markers cannot fix the
        pose, or the fit wanders beyond :data:`POSE_MAX_SAG`) and the rms distance (m)
        left between the placed markers and their readings: the markers' shape on the
        tool against the cell file's.
    """
    q = np.asarray(q, dtype=float)
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    robot = cell.robot
    if len(points) < POSE_MIN_MARKERS:
        return q, 0.0
    estimate = q.copy()
    for _ in range(POSE_ITERATIONS):
        residual = (positions - robot.point_position(estimate, points)).reshape(-1)
        jacobian = np.vstack([robot.point_jacobian(estimate, point) for point in points])
        step, *_ = np.linalg.lstsq(jacobian, residual, rcond=None)
        estimate = estimate + step
        if np.max(np.abs(step)) < POSE_TOLERANCE:
            break
    misfit = float(np.sqrt(np.mean((positions - robot.point_position(estimate, points)) ** 2)))
    # A pose far from the commanded one means markers that are not where they were taken to be.
    return (estimate, misfit) if np.max(np.abs(estimate - q)) < POSE_MAX_SAG else (q, misfit)


def predicted_pose(cell: Cell, q) -> np.ndarray:
    """Link angles (rad) of the unloaded arm at the commanded ``q``: its sag under its weight with the cell's stiffness."""
    arm = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, compensated_joint=cell.compensated_joint)
    try:
        return np.asarray(q, dtype=float) + arm.equilibrium(q, np.zeros(6))
    except EquilibriumError:
        return np.asarray(q, dtype=float)


def wrench_at_pose(cell: Cell, campaign: Campaign, q: np.ndarray) -> np.ndarray:
    """(N, 6) the campaign's wrenches referred to the flange origin with the tool at the link angles ``q`` (rad).

    A campaign records the wrench with the arm at its commanded angles.  The
    load's force acts at its point on the tool (the campaign's ``load_*_mm``
    columns, else the cell's load point), which turns with the tool when the
    arm sags; the rest of the recorded couple is a dead couple, as in
    :func:`bayescal.inference.equations.check_load_point`.  A sag of 2° turns the
    KR-270 tool's 390 mm lever under 2750 N by up to 37 N·m, which the wrist
    joints turn into tens of μm at the markers.
    """
    wrench = np.array(campaign.wrench, dtype=float)
    points = np.broadcast_to(cell.load_point, (len(campaign), 3)) if campaign.load_point is None else campaign.load_point
    commanded = np.asarray(campaign.q, dtype=float)
    for i in np.flatnonzero(np.any(q != commanded, axis=1)):
        turned = cell.robot.flange_pose(q[i])[0] - cell.robot.flange_pose(commanded[i])[0]
        wrench[i, 3:] += np.cross(turned @ points[i], wrench[i, :3])
    return wrench


def campaign_rows(cell: Cell, campaign: Campaign) -> Rows:
    """The rows of a campaign at the arm's measured unloaded poses (:func:`measured_pose`), the load's wrench
    referred to them (:func:`wrench_at_pose`)."""
    robot = cell.robot
    q = np.asarray(campaign.q, dtype=float).copy()
    measured, shape = q.copy(), []
    for config in np.unique(campaign.config):
        rows = np.flatnonzero(campaign.config == config)
        names = campaign.marker[rows].astype(str)
        unique = [name for name in sorted(set(names)) if name in cell.markers]
        mean = np.array([campaign.p0[rows[names == name]].mean(axis=0) for name in unique]).reshape(-1, 3)
        measured[rows], misfit = measured_pose(cell, q[rows[0]], np.array([cell.markers[name] for name in unique]), mean)
        shape.append(misfit)
    if shape and np.median(shape) <= POSE_SHAPE_FACTOR * np.median(cell.tracker.sigma(campaign.p0)):
        q = measured
    else:
        # The markers are not where the cell file puts them (or are too few): a pose fitted to
        # them would turn the whole design; the sag the cell's own stiffness predicts serves instead.
        configs, first = np.unique(campaign.config, return_index=True)
        sagged = {int(c): predicted_pose(cell, campaign.q[i]) for c, i in zip(configs, first)}
        q = np.array([sagged[int(c)] for c in campaign.config])
    point = np.array([robot.point_in_flange(qi, p) for qi, p in zip(q, campaign.p0)])
    # the tracker's two readings, and what the campaign's frame adds (a registration's or a removed drift's)
    variance = cell.tracker.deflection_variance(campaign.p0, campaign.p1)
    sd = np.sqrt(variance if campaign.added_variance is None else variance + campaign.added_variance)
    return _build(
        cell,
        q,
        wrench_at_pose(cell, campaign, q),
        point,
        np.asarray(campaign.p0, dtype=float),
        campaign.displacement,
        np.asarray(campaign.config, dtype=int),
        np.asarray(campaign.repeat, dtype=int),
        np.asarray(campaign.marker).astype(str),
        sd / sd.mean(),
        campaign.times,
        campaign.q,
    )


def pose_rows(cell: Cell, q, wrench, point, config=None) -> Rows:
    """Rows for tool points at poses under wrenches, without measurements: for predictions and plans.

    Parameters
    ----------
    q
        (nq,) or (N, nq) joint angles, rad.
    wrench
        (6,) or (N, 6) load at the flange origin, base axes, N and N·m.
    point
        (3,) or (N, 3) the point on the tool, flange frame, m.
    config
        (N,) configuration labels (default: all 0).
    """
    q = np.asarray(q, dtype=float).reshape(-1, cell.robot.nq)
    n = len(q)
    point = np.broadcast_to(np.asarray(point, dtype=float).reshape(-1, 3), (n, 3)).copy()
    workspace = cell.robot.workspace()
    position = np.array([workspace.point_position(qi, p.reshape(1, 3)).reshape(3) for qi, p in zip(q, point)])
    return _build(
        cell,
        q,
        np.broadcast_to(np.asarray(wrench, dtype=float).reshape(-1, 6), (n, 6)).copy(),
        point,
        position,
        np.zeros((n, 3)),
        np.zeros(n, dtype=int) if config is None else np.asarray(config, dtype=int),
        np.ones(n, dtype=int),
        np.full(n, PREDICTED_MARKER),
        np.ones(n),
    )
