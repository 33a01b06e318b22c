"""An independent simulator of absolute marker positions on a humanoid upper body (DLR's Agile Justin).

Written from first principles, apart from the package's kinematics, so that a calibration
method can be tested on data it was not built from: plain-numpy forward kinematics of the
published nominal modified-DH table, a random truth per world and the static equilibrium
under the robot's own weight.  SI inside; mm, deg and μrad/(N·m) only at the edges.

Each DH column is ``Rx(α + δα)·Ry(β)·Tx(r + δr)·Rz(θ + δθ + (1 + ε)·q)·Tz(d + δd)`` from its
predecessor.  Columns: torso 1..4 (``q_t4 = -(q_t2 + q_t3)``), right arm 1..7, left arm 1..7.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from bayescal.errors import InputError
from bayescal.units import DEG, MM, URAD_PER_NM

__all__ = ["PointsWorld", "draw_world", "configurations", "marker_positions", "positions_frame", "write_positions"]

# Nominal modified-DH table (d m, θ deg, r m, α deg), one row per column.
_TORSO = [(0.1055, 0, 0, 0), (0, -90, 0, -90), (0, 0, 0.3, 0), (0, 0, 0.3, 0)]
_RIGHT = [(0, 0, 0, 0), (0, 0, 0, 90), (0.4, -90, 0, -90), (0, 0, 0, 90), (0.39, -180, 0, -90), (0, 90, 0, 90), (0, -90, 0, 90)]
_LEFT = [(0, 0, 0, 180), (0, 0, 0, 90), (-0.4, -90, 0, -90), (0, 0, 0, 90), (-0.39, 0, 0, -90), (0, 90, 0, -90), (0, -90, 0, -90)]
_DH = np.array(_TORSO + _RIGHT + _LEFT, dtype=float) * [1.0, DEG, 1.0, DEG]
_ARMS = (np.arange(4, 11), np.arange(11, 18))  # columns of the right and the left arm; 0..3 are the torso
_LAST = np.array([17] * 4 + [10] * 7 + [17] * 7)[:, None]  # the last column hanging off each joint
# _DISTAL[j, k]: column k's masses hang off joint j (the rest of its arm, or everything above a torso joint).
_DISTAL = (np.arange(18) >= np.arange(18)[:, None]) & (np.arange(18) <= _LAST)
NAMES = [f"torso_{i}" for i in range(1, 5)] + [f"{s}_{i}" for s in ("right", "left") for i in range(1, 8)]
MARKERS = ("right", "left")


def _rot(axis, a):
    """(..., 3, 3) rotations about x, y or z (``axis`` 0, 1 or 2) by angles ``a`` (...) rad."""
    a = np.asarray(a, dtype=float)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.zeros(a.shape + (3, 3))
    out[..., axis, axis] = 1.0
    out[..., i, i] = out[..., j, j] = np.cos(a)
    out[..., i, j], out[..., j, i] = -np.sin(a), np.sin(a)
    return out


def _pose(rotation, translation):
    """(4, 4) homogeneous transform."""
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = rotation, translation
    return pose


def _exp(w):
    """Rotation matrices (..., 3, 3) of rotation vectors ``w`` (..., 3) rad (Rodrigues); exactly I at 0."""
    angle = np.linalg.norm(w, axis=-1)[..., None, None]
    safe = np.where(angle > 0, angle, 1.0)
    k = np.zeros(w.shape + (3,))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -w[..., 2], w[..., 1], -w[..., 0]
    k -= np.swapaxes(k, -1, -2)
    return np.eye(3) + np.sin(safe) / safe * k + np.where(angle > 0, (1 - np.cos(safe)) / safe**2, 0.5) * k @ k


# The nominal robot in its cell.
BASE = _pose(_rot(2, 90 * DEG), [-2.5, 2.0, 0.1])  # the base in the tracker frame, m
MOUNTS = np.array([_pose(_rot(2, a * DEG), [0, 0, z]) for a, z in [(30, 0.25), (-30, -0.25)]])  # in torso frame 3
MARKER_POINTS = np.array([[-0.1, -0.03, 0.1], [-0.1, 0.03, 0.05]])  # (right, left) in the last arm frame, m
GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s², in the tracker frame
UPPER_TORSO = np.array([0.1, 0.0, 0.0])  # upper torso and head's centre in torso frame 3 (x: up the spine), m
JOINT_RANGES = np.array(
    [[-2.28, 3.47], [-1.56, 0.19], [0.02, 2.35]]
    + [[-2.95, 2.95], [-2.04, 2.09], [-2.95, 2.96], [-2.05, 2.08], [-2.96, 2.96], [-0.78, 1.39], [-0.77, 2.35]] * 2
    + [[0.0, 0.0]] * 2
)  # (19, 2) rad: the commanded joints' ranges in the real data set; the head's two held at 0

# The truth's spreads (sd per axis unless said), each the size a real robot of this kind has.
DH_THETA_SD = 0.3 * DEG  # joint offsets: encoder zeroing is good to a few tenths of a degree
DH_LENGTH_SD = 1.0 * MM  # δd, δr: machining and assembly tolerances of 0.3-0.4 m aluminium links
DH_ALPHA_SD = 0.2 * DEG  # δα: bearing seats misaligned by about 1 mm over 0.3 m
DH_BETA_SD = 0.1 * DEG  # β about y (Hayati): the tilt δα cannot express, of the same origin but smaller
GEAR_RATIO_SD = 1e-3  # relative, off by default: harmonic-drive ratios are exact, a belt stage's nearly so
MOUNT_TRANSLATION_SD, MOUNT_ROTATION_SD = 5.0 * MM, 1.0 * DEG  # a bolted interface no published table gives
MARKER_SD = 5.0 * MM  # a marker stuck on the hand is only roughly where it was meant to be
BASE_TRANSLATION_SD, BASE_ROTATION_SD = 20.0 * MM, 2.0 * DEG  # the robot placed in the cell by eye and tape
MASS_SPREAD = 0.3  # uniform ±30 % of nominal: cables, covers and electronics are on no drawing
# Nominal masses (kg) per column: its drive at its origin, its link at LINK_POINTS.  Torso drives and links,
# the upper torso with head (20 kg); per arm 10 kg of drives (LWR-III-like), upper arm, forearm, hand (2 kg): 16 kg.
DRIVE_MASSES = np.array([0.0, 4.0, 3.0, 2.0] + [2.0, 2.0, 1.6, 1.6, 1.2, 0.8, 0.8] * 2)
LINK_MASSES = np.array([0.0, 6.0, 5.0, 20.0] + [0.0, 2.2, 0.0, 1.8, 0.0, 0.0, 2.0] * 2)
ARM_COMPLIANCE = (20 * URAD_PER_NM, 300 * URAD_PER_NM)  # log-uniform range: harmonic drives with torque sensors
TORSO_COMPLIANCE = (5 * URAD_PER_NM, 50 * URAD_PER_NM)  # log-uniform range: larger drives, about 10 times stiffer
TRANSVERSAL_RATIO = 1.0 / 3.0  # about x and y of a joint: crossed-roller bearings tilt less than gears twist
OUTLIER_SD = 20.0 * MM  # a gross outlier is a swapped or reflected marker, off by centimetres
MIN_MARKER_HEIGHT = 0.3  # m, tracker frame: hands near the floor and the mobile base were not measured
TOLERANCE = 1e-9  # m: the equilibrium is converged when an iteration moves no marker by this much
MAX_ITERATIONS = 100  # the iteration contracts by about 2e-2 an iteration at these compliances: 6-7 suffice


def _link_points():
    """(18, 3) each column's link mass in its frame: halfway to the next origin, or the upper torso, or a hand."""
    d, _, r, alpha = _DH.T
    nxt = np.stack([r, -d * np.sin(alpha), d * np.cos(alpha)], axis=1)  # next origin in this frame, any q
    points = np.zeros((18, 3))
    for cols in (np.arange(3), *(a[:-1] for a in _ARMS)):
        points[cols] = nxt[cols + 1] / 2
    points[3] = UPPER_TORSO
    points[[_ARMS[0][-1], _ARMS[1][-1]]] = MARKER_POINTS
    return points


LINK_POINTS = _link_points()


@dataclass(frozen=True)
class PointsWorld:
    """The truth of one simulated world, SI units.

    Attributes
    ----------
    base : (4, 4) pose of the robot base in the tracker frame.
    mounts : (2, 4, 4) shoulder mounts (right, left) in torso frame 3.
    markers : (2, 3) markers (right, left) in the last arm frame, m.
    dh_errors : (18, 5) per column δθ (rad), δd (m), δr (m), δα (rad), β (rad).
    gear_errors : (18,) relative gear-ratio error ε of each column's joint.
    masses : (18, 2) kg, per column the drive at its origin and the link at ``LINK_POINTS``.
    compliances : (18, 3) rad/(N·m) about the x, y and z (joint) axes of each column's frame.
    noise_sd : tracker noise per coordinate, m.
    outlier_fraction : probability of a gross outlier per reading.
    """

    base: np.ndarray
    mounts: np.ndarray
    markers: np.ndarray
    dh_errors: np.ndarray
    gear_errors: np.ndarray
    masses: np.ndarray
    compliances: np.ndarray
    noise_sd: float
    outlier_fraction: float = 0.0

    def to_json(self) -> dict:
        """The truth as a plain dict, in mm, deg, kg and μrad/(N·m)."""

        def pose(p):
            rotation = Rotation.from_matrix(p[:3, :3]).as_rotvec(degrees=True)
            return {"translation_mm": (p[:3, 3] / MM).tolist(), "rotation_vector_deg": rotation.tolist()}

        e, k = self.dh_errors, self.compliances / URAD_PER_NM
        per_joint = {
            "delta_theta_deg": e[:, 0] / DEG, "delta_d_mm": e[:, 1] / MM, "delta_r_mm": e[:, 2] / MM,
            "delta_alpha_deg": e[:, 3] / DEG, "beta_deg": e[:, 4] / DEG, "gear_ratio_error": self.gear_errors,
            "drive_mass_kg": self.masses[:, 0], "link_mass_kg": self.masses[:, 1],
            "compliance_x_urad_per_nm": k[:, 0], "compliance_y_urad_per_nm": k[:, 1],
            "compliance_z_urad_per_nm": k[:, 2],
        }  # fmt: skip
        joints = [{"name": name, **{key: float(v[i]) for key, v in per_joint.items()}} for i, name in enumerate(NAMES)]
        return {
            "base": pose(self.base),
            "shoulder_mounts": {name: pose(p) for name, p in zip(MARKERS, self.mounts)},
            "markers_mm": {name: (p / MM).tolist() for name, p in zip(MARKERS, self.markers)},
            "joints": joints,
            "noise_sd_mm": self.noise_sd / MM,
            "outlier_fraction": self.outlier_fraction,
        }


def _perturb(rng, pose, translation_sd, rotation_sd):
    """``pose`` moved by a random rotation and translation of the given sd per axis, in its own frame."""
    return pose @ _pose(_exp(rng.normal(0, rotation_sd, 3)), rng.normal(0, translation_sd, 3))


def draw_world(
    rng: np.random.Generator, *, noise_sd: float = 1e-4, elastic: bool = True, transversal: bool = True,
    kinematic_errors: bool = True, gear_ratios: bool = False, outlier_fraction: float = 0.0,
) -> PointsWorld:  # fmt: skip
    """One random world.

    Everything is drawn in the same order whatever the flags, which only zero
    effects afterwards: one seed gives the same remaining truth with an effect off.

    Parameters
    ----------
    rng : the random generator.
    noise_sd : tracker noise per coordinate, m.
    elastic : self-weight deflection (all compliances zero when off).
    transversal : compliances across the joint axes (x and y of the joint frame).
    kinematic_errors : DH errors and perturbed shoulder mounts, markers and base.
    gear_ratios : joint gear-ratio errors.
    outlier_fraction : probability of a gross outlier (``OUTLIER_SD`` per axis) per reading.
    """
    if noise_sd < 0 or not 0 <= outlier_fraction <= 1:
        raise InputError(f"noise_sd must be >= 0 and outlier_fraction in [0, 1], got {noise_sd}, {outlier_fraction}")
    dh = rng.normal(size=(18, 5)) * [DH_THETA_SD, DH_LENGTH_SD, DH_LENGTH_SD, DH_ALPHA_SD, DH_BETA_SD]
    gear = rng.normal(0, GEAR_RATIO_SD, 18)
    mounts = np.array([_perturb(rng, m, MOUNT_TRANSLATION_SD, MOUNT_ROTATION_SD) for m in MOUNTS])
    markers = MARKER_POINTS + rng.normal(0, MARKER_SD, (2, 3))
    base = _perturb(rng, BASE, BASE_TRANSLATION_SD, BASE_ROTATION_SD)
    masses = np.stack([DRIVE_MASSES, LINK_MASSES], axis=1) * rng.uniform(1 - MASS_SPREAD, 1 + MASS_SPREAD, (18, 2))
    low, high = np.log(np.array([TORSO_COMPLIANCE] * 4 + [ARM_COMPLIANCE] * 14)).T
    k_theta = np.exp(rng.uniform(low, high))
    compliances = k_theta[:, None] * [TRANSVERSAL_RATIO * transversal, TRANSVERSAL_RATIO * transversal, 1.0] * elastic
    if not kinematic_errors:
        dh, mounts, markers, base = np.zeros((18, 5)), MOUNTS.copy(), MARKER_POINTS.copy(), BASE.copy()
    return PointsWorld(base, mounts, markers, dh, gear * gear_ratios, masses, compliances, noise_sd, outlier_fraction)


def _columns(world, joints):
    """(n, 18, 4, 4) transforms of the columns from their predecessors at commanded ``joints`` (n, 19)."""
    q = np.concatenate([joints[:, :3], -(joints[:, 1:3].sum(1, keepdims=True)), joints[:, 3:17]], axis=1)
    d, theta, r, alpha = (_DH + world.dh_errors[:, [1, 0, 2, 3]]).T
    tilt = _rot(0, alpha) @ _rot(1, world.dh_errors[:, 4])
    fixed = np.zeros((18, 4, 4))
    fixed[:, :3, :3], fixed[:, :3, 3], fixed[:, 3, 3] = tilt, tilt[..., 0] * r[:, None], 1.0
    moving = np.zeros(q.shape + (4, 4))
    moving[..., :3, :3], moving[..., 2, 3], moving[..., 3, 3] = _rot(2, theta + (1 + world.gear_errors) * q), d, 1.0
    return fixed @ moving


def _forward(world, columns, phi):
    """Joint frames before their deflection (n, 18, 4, 4), after it (n, 18, 4, 4), markers (n, 2, 3), tracker frame.

    ``phi`` (n, 18, 3) rad: each joint's deflection, a rotation of its distal part
    about the joint origin, in the joint frame.
    """
    bend = np.zeros(phi.shape[:-1] + (4, 4))
    bend[..., :3, :3], bend[..., 3, 3] = _exp(phi), 1.0
    before, after = np.empty_like(columns), np.empty_like(columns)

    def chain(parent, cols):
        for j in cols:
            before[:, j] = parent @ columns[:, j]
            after[:, j] = parent = before[:, j] @ bend[:, j]

    chain(world.base, range(4))
    for arm, mount in zip(_ARMS, world.mounts):
        chain(after[:, 3] @ mount, arm)
    last = after[:, [_ARMS[0][-1], _ARMS[1][-1]]]
    return before, after, np.einsum("nmij,mj->nmi", last[..., :3, :3], world.markers) + last[..., :3, 3]


def _step(world, columns, phi):
    """Deflections (n, 18, 3) under the gravity moments of the configuration deflected by ``phi``."""
    before, after, _ = _forward(world, columns, phi)
    origins = after[..., :3, 3]
    links = np.einsum("nkij,kj->nki", after[..., :3, :3], LINK_POINTS) + origins
    first = world.masses[:, 0, None] * origins + world.masses[:, 1, None] * links  # Σ m·c per column
    # Σ m·(c - p) × g over everything distal to each joint, about its origin p.
    moment = np.cross(_DISTAL @ first - (_DISTAL @ world.masses.sum(1))[:, None] * origins, GRAVITY)
    # C = R·diag(k)·Rᵀ in the joint frame: the deflection in that frame is diag(k)·Rᵀ·moment.
    return world.compliances * np.einsum("nkji,nkj->nki", before[..., :3, :3], moment)


def _solve(world, columns):
    """Equilibrium deflections (n, 18, 3) rad, by fixed-point iteration until the markers move < ``TOLERANCE``."""
    phi = np.zeros(columns.shape[:2] + (3,))
    markers = _forward(world, columns, phi)[2]
    for _ in range(MAX_ITERATIONS):
        phi = _step(world, columns, phi)
        moved, markers = markers, _forward(world, columns, phi)[2]
        if np.max(np.abs(markers - moved)) < TOLERANCE:
            return phi
    raise RuntimeError(f"self-weight equilibrium not converged in {MAX_ITERATIONS} iterations")


def _check_joints(joints):
    joints = np.asarray(joints, dtype=float)
    if joints.ndim != 2 or joints.shape[1] != 19:
        raise InputError(f"expected joint angles of shape (n, 19), got {joints.shape}")
    return joints


def marker_positions(
    world: PointsWorld, joints: np.ndarray, *, noise_rng: np.random.Generator | None = None
) -> np.ndarray:
    """(n, 2, 3) marker positions (right, left) in the tracker frame, m.

    Parameters
    ----------
    world : the truth.
    joints : (n, 19) commanded joint angles, rad.
    noise_rng : draws the tracker noise and outliers; noiseless when None.
    """
    joints = _check_joints(joints)
    columns = _columns(world, joints)
    positions = _forward(world, columns, _solve(world, columns))[2]
    if noise_rng is not None:
        positions = positions + noise_rng.normal(0, world.noise_sd, positions.shape)
        gross = noise_rng.random(positions.shape[:2]) < world.outlier_fraction
        positions[gross] += noise_rng.normal(0, OUTLIER_SD, (gross.sum(), 3))
    return positions


# The nominal rigid robot, which decides which configurations keep the hands above the table.
_NOMINAL = PointsWorld(BASE, MOUNTS, MARKER_POINTS, *(np.zeros(shape) for shape in [(18, 5), 18, (18, 2), (18, 3)]), 0.0)


def configurations(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 19) commanded joint angles (rad), uniform in ``JOINT_RANGES``, nominal hands above ``MIN_MARKER_HEIGHT``."""
    if n < 0:
        raise InputError(f"expected a number of configurations >= 0, got {n}")
    kept = np.empty((0, 19))
    while len(kept) < n:
        draws = rng.uniform(JOINT_RANGES[:, 0], JOINT_RANGES[:, 1], (2 * n, 19))
        height = marker_positions(_NOMINAL, draws)[..., 2].min(axis=1)
        kept = np.concatenate([kept, draws[height >= MIN_MARKER_HEIGHT]])
    return kept[:n]


def positions_frame(joints: np.ndarray, positions: np.ndarray) -> pd.DataFrame:
    """The positions-file table: ``q1_deg..q19_deg, marker, x_mm, y_mm, z_mm``, right then left per configuration.

    Parameters
    ----------
    joints : (n, 19) commanded joint angles, rad.
    positions : (n, 2, 3) marker positions (right, left), m.
    """
    joints, positions = _check_joints(joints), np.asarray(positions, dtype=float)
    if positions.shape != (len(joints), 2, 3):
        raise InputError(f"expected positions of shape ({len(joints)}, 2, 3), got {positions.shape}")
    frame = pd.DataFrame(np.repeat(joints / DEG, 2, axis=0), columns=[f"q{i}_deg" for i in range(1, 20)])
    frame["marker"] = np.tile(MARKERS, len(joints))
    frame[["x_mm", "y_mm", "z_mm"]] = positions.reshape(-1, 3) / MM
    return frame


def write_positions(
    path: str | PathLike[str], joints: np.ndarray, positions: np.ndarray, *, header: str | None = None
) -> None:
    """Write :func:`positions_frame` as CSV: plain decimals to 1e-9 deg and 1e-9 mm, no index.

    ``header``, if given, leads the file as ``# `` comment lines (e.g. naming the source and seed).
    """
    frame = positions_frame(joints, positions)
    with open(path, "w", newline="") as out:
        for line in (header.splitlines() if header else []):
            out.write(f"# {line}\n")
        frame.to_csv(out, index=False, float_format="%.9f")
