"""Registering the tracker to the robot: every swept joint's axis and the robot's frames, in the tracker frame."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.errors import InputError
from bayescal.jsonfiles import JsonFindings, JsonSchema
from bayescal.output import record_read
from bayescal.registration.axes import AxisFit, fit_axis, span_needed
from bayescal.registration.frames import Frame, common_perpendicular, draw_axis, frames_with_uncertainty, urdf_axes
from bayescal.registration.sweeps import Sweeps
from bayescal.units import DEG, MM

__all__ = ["Registration", "RegistrationFindings", "exclude", "read_frame", "register", "MIRROR_Z", "REGISTRATION_JSON"]

REGISTRATION_JSON = JsonSchema({"axes": dict, "frames": dict}, "bayescal axes -o", foreign="parameters")
"""What a reader of :meth:`Registration.save`'s file relies on; ``parameters`` is a calibration's key."""

MIRROR_Z = 5.0
"""Standard deviations by which the offset between axes 1 and 2 must sit nearer the URDF's mirror image than the URDF's
own for the tracker frame to be called mirrored: an offset flipped by a left-handed frame (x and y swapped) moves by
twice the URDF's offset, 700 mm on the KR-270 against an sd of a few tenths of a mm."""


@dataclass(frozen=True)
class Registration:
    """The axes of the swept joints and, when joints 1 and 2 were swept, the paper and base frames.

    Attributes
    ----------
    axes
        0-based joint index -> its :class:`AxisFit` (tracker frame).
    frames
        ``"paper"`` and ``"base"`` -> :class:`Frame` (empty without sweeps of joints 1 and 2).
    home
        (nq,) the joint angles the sweeps start from (the other joints' angles in each sweep), rad.
    source
        The sweep file.
    robot
        The name of the robot it was made with (its URDF's ``<robot name>``), which :func:`read_frame` checks.
    left_out
        0-based joint -> why its sweep gave no axis (too short to determine it).
    missing
        What the frames lack and the sweep that would give it ("" when both frames are built).
    excluded
        ``{"joints": [1-based …], "markers": […]}``: what the user left out.
    """

    axes: dict[int, AxisFit]
    frames: dict[str, Frame]
    home: np.ndarray
    source: str
    robot: str = ""
    left_out: dict[int, str] = field(default_factory=dict)
    missing: str = ""
    excluded: dict = field(default_factory=lambda: {"joints": [], "markers": []})

    def summary(self) -> pd.DataFrame:
        """One row per swept joint: axis, its sd (mrad, mm), arc residual rms (mm)."""
        return pd.concat([fit.summary() for fit in self.axes.values()], ignore_index=True)

    def diagnostics(self) -> pd.DataFrame:
        """One row per joint and reflector: radius, height, phase, residual rms, standardised rms, and the fit's chi²/dof."""
        rows = []
        for j, fit in self.axes.items():
            table = fit.diagnostics()
            table.insert(0, "joint", j + 1)
            table["chi2_per_dof"] = fit.chi2 / max(fit.dof, 1)
            rows.append(table)
        return pd.concat(rows, ignore_index=True)

    def to_json(self) -> dict:
        """``{"axes": {"1": …}, "frames": {"paper": …, "base": …}, "home_deg": […], "source": …, "robot": …}``."""
        return {
            "axes": {str(j + 1): fit.to_json() for j, fit in self.axes.items()},
            "frames": {name: frame.to_json() for name, frame in self.frames.items()},
            "home_deg": (self.home / DEG).tolist(),
            "source": self.source,
            "robot": self.robot,
            "left_out": {str(j + 1): why for j, why in self.left_out.items()},
            "missing": self.missing,
            "excluded": self.excluded,
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to a JSON file."""
        with open(path, "w", encoding="utf-8") as out:
            json.dump(self.to_json(), out, indent=2)



@dataclass(frozen=True)
class RegistrationFindings(JsonFindings):
    """What a registration's JSON file (:meth:`Registration.save`) holds.

    Attributes
    ----------
    axes : dict
        Joint ("1", …) -> its axis in the tracker frame: ``direction`` (unit vector) and ``direction_sd_mrad`` (mrad),
        ``point_mm`` and ``point_sd_mm`` (mm), ``rms_mm`` (mm), ``chi2``, ``dof``, ``reflectors`` (arc residuals, mm and
        deg) and, in a newer file, ``half_width`` and ``direction_dof``, ``point_dof``.
    frames : dict
        Frame name -> ``rotation`` (3 x 3), ``rotation_sd_mrad`` (mrad, 3), ``translation_mm`` and ``translation_sd_mm``
        (mm, 3), ``from_nominal`` when built from the nominal geometry.
    left_out : dict or None
        Joint -> why its sweep gave no axis.
    missing : str or None
        What the registration lacks, in words.
    critique : dict or None
        The sweep critique: ``verdict`` and, per joint, each candidate's held-out ``evidence``.
    keys : tuple of str
        The file's keys in its order (a key held as null apart from one missing).
    extra : dict
        The file's other keys, as they came.
    """

    axes: dict
    frames: dict
    left_out: dict | None = None
    missing: str | None = None
    critique: dict | None = None
    keys: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)

    SCHEMA = REGISTRATION_JSON
    OPTION = "--registration"
    NAME = "the registration's JSON"



def _home(sweeps: Sweeps, nq: int) -> np.ndarray:
    """The home angles: each joint's angle in the sweeps of the other joints (all sweeps must share them)."""
    if sweeps.q.shape[1] != nq:
        raise InputError(f"expected {nq} joint-angle columns q1_deg … q{nq}_deg for the cell's robot, got {sweeps.q.shape[1]}",
                         source=sweeps.source, line=1)
    home = np.full(nq, np.nan)
    for j in sweeps.swept_joints:
        s = sweeps.of(j)
        for k in range(nq):
            if k == j:
                continue
            if np.isnan(home[k]):
                home[k] = s.q[0, k]
            elif abs(s.q[0, k] - home[k]) > 1e-6 * DEG:
                raise InputError(f"the sweep of joint {j + 1} starts from q{k + 1} = {s.q[0, k] / DEG:.6g} deg, the others "
                                 f"from {home[k] / DEG:.6g} deg: sweep every joint from one home pose",
                                 source=sweeps.source, line=int(s.line[0]), column=f"q{k + 1}_deg")
    # A joint moved in its own sweep only, and never held still elsewhere: its first angle stands for home.
    for j in range(nq):
        if np.isnan(home[j]):
            home[j] = sweeps.of(j).q[0, j] if j in sweeps.swept_joints else 0.0
    return home


def exclude(sweeps: Sweeps, joints=(), markers=()) -> Sweeps:
    """The readings without the sweeps of ``joints`` (0-based) and without the reflectors ``markers``.

    Raises
    ------
    InputError
        A joint not swept (source ``"joints"``) or a reflector not read (source ``"markers"``).
    """
    for j in joints:
        if j not in sweeps.swept_joints:
            raise InputError(f"expected one of the joints swept in {sweeps.source} "
                             f"({', '.join(str(k + 1) for k in sweeps.swept_joints)}), got {j + 1}", source="joints")
    names = list(dict.fromkeys(sweeps.marker))
    for name in markers:
        if name not in names:
            raise InputError(f"expected one of the reflectors read in {sweeps.source} ({', '.join(names)}), got '{name}'",
                             source="markers")
    keep = ~np.isin(sweeps.joint, list(joints)) & ~np.isin(sweeps.marker, list(markers))
    if not keep.any():
        raise InputError(f"nothing left of {sweeps.source} to fit once they are left out", source="joints" if joints else "markers")
    return Sweeps(sweeps.joint[keep], sweeps.q[keep], sweeps.marker[keep], sweeps.xyz[keep], sweeps.line[keep], sweeps.source)


def _check_repeated(sweeps: Sweeps) -> None:
    """Refuse a reading that repeats another to the last digit: a tracker never reads a point twice alike."""
    seen: dict[tuple, int] = {}
    for row in range(len(sweeps.joint)):
        key = (int(sweeps.joint[row]), str(sweeps.marker[row]), *sweeps.q[row].tolist(), *sweeps.xyz[row].tolist())
        if key in seen:
            raise InputError(f"this reading repeats line {seen[key]} to the last digit (joint angles, reflector and position): "
                             "a tracker never reads a point twice alike, and a copy would count as a second reading and "
                             "shrink the sds; remove the repeated rows", source=sweeps.source, line=int(sweeps.line[row]))
        seen[key] = int(sweeps.line[row])


def _check_handedness(first: AxisFit, second: AxisFit, nominal, rng: np.random.Generator, source: str) -> None:
    """Refuse a tracker frame that is the mirror image of the robot's (left-handed: two of its axes swapped).

    A rotation keeps the signed offset of axis 2 from axis 1 along ``a1 × a2``; a mirror flips its sign.  Compared
    with the URDF's at the home pose, the fitted offset must not be nearer the URDF's mirror image by :data:`MIRROR_Z` sd.
    """
    def offset(a1, c1, a2, c2) -> float:
        foot1, foot2 = common_perpendicular(a1, c1, a2, c2)
        n = np.cross(a1, a2)
        return float((foot2 - foot1) @ n / np.linalg.norm(n))

    (u1, p1), (u2, p2) = nominal
    expected = offset(u1, p1, u2, p2)
    measured = offset(first.direction, first.point, second.direction, second.point)
    (d1, c1), (d2, c2) = draw_axis(first, rng, 200), draw_axis(second, rng, 200)
    sd = float(np.std([offset(d1[k], c1[k], d2[k], c2[k]) for k in range(200)]))
    if abs(measured + expected) + MIRROR_Z * sd < abs(measured - expected):
        raise InputError(
            f"the tracker frame is the mirror image of the robot's: axis 2 sits {measured / MM:+.1f} mm from axis 1 along "
            f"a1 × a2 (sd {sd / MM:.2g} mm), where the URDF puts it {expected / MM:+.1f} mm; a left-handed frame, "
            "x_mm and y_mm swapped or one of them negated?", source=source, column="x_mm")


def _missing(axes: dict[int, AxisFit], left_out: dict[int, str]) -> str:
    """What the frames lack, and the sweep that would give it; "" when axes 1 and 2 are both fitted."""
    lacking = [j for j in (0, 1) if j not in axes]
    if not lacking:
        return ""
    asks = [f"joint {j + 1} {'longer (its sweep is too short)' if j in left_out else ''}".strip() for j in lacking]
    return f"no base frame and no paper frame: sweep {' and '.join(asks)} (both frames are built from the axes of joints 1 and 2)"


def register(sweeps: Sweeps, cell: Cell, rng: np.random.Generator | int | None = 0, draws: int = 400, *,
             exclude_joints=(), exclude_markers=()) -> Registration:
    """Fit every swept joint's axis and, if joints 1 and 2 were swept, the paper and base frames.

    Parameters
    ----------
    sweeps
        The tracker-frame readings.
    cell
        Gives the tracker noise (taken at the tracker origin) and the robot's URDF.
    rng
        Seed or generator of the draws that propagate the axes' uncertainty to the frames.
    draws
        Number of such draws.
    exclude_joints, exclude_markers
        Sweeps (0-based joints) and reflectors (names) to leave out (:func:`exclude`).

    Raises
    ------
    InputError
        A reading repeated to the last digit, a mislabelled reflector (:func:`~bayescal.registration.axes.fit_axis`),
        a tracker frame that is the mirror image of the robot's, or nothing left to fit.

    A sweep too short to determine its joint's axis (:func:`~bayescal.registration.axes.span_needed`) is left out and
    named in :attr:`Registration.left_out`; frames that cannot be built are named in :attr:`Registration.missing`.
    """
    rng = np.random.default_rng(rng)
    noise = replace(cell.tracker, position=np.zeros(3))
    sweeps = exclude(sweeps, exclude_joints, exclude_markers) if len(exclude_joints) or len(exclude_markers) else sweeps
    home = _home(sweeps, cell.robot.nq)
    _check_repeated(sweeps)
    axes, left_out = {}, {}
    for j in sweeps.swept_joints:
        needed = span_needed(sweeps, j, noise)
        if needed is None:
            fit = fit_axis(sweeps, j, noise)
            needed = span_needed(sweeps, j, noise, fit.excess)
        if needed is None:
            axes[j] = fit
        else:
            span = float(np.ptp(sweeps.of(j).q[:, j]))
            left_out[j] = (f"over {span / DEG:.3g} deg is too short to determine its axis: its arcs bend less than the "
                           f"noise allows; sweep at least {np.ceil(needed / DEG):.0f} deg")
    frames: dict[str, Frame] = {}
    if 0 in axes and 1 in axes:
        nominal = urdf_axes(cell.robot, home)
        _check_handedness(axes[0], axes[1], nominal, rng, sweeps.source)
        frames = {f.name: f for f in frames_with_uncertainty(axes[0], axes[1], nominal, rng, draws)}
    excluded = {"joints": sorted(int(j) + 1 for j in exclude_joints), "markers": list(exclude_markers)}
    return Registration(axes, frames, home, sweeps.source, robot=cell.robot.model.name, left_out=left_out,
                        missing=_missing(axes, left_out), excluded=excluded)


def read_frame(path: str | PathLike[str], name: str, cell: Cell | None = None) -> Frame:
    """The frame ``name`` (``"paper"`` or ``"base"``) of a registration file written by :meth:`Registration.save`.

    Parameters
    ----------
    path
        The registration file.
    name
        The frame to read.
    cell
        The cell the registration is applied to: its robot's joints and name are checked
        against the file's home pose and robot; ``None`` checks the file alone.

    Raises
    ------
    InputError
        Not JSON, no such frame, a rotation that is not a 3×3 rotation matrix (to 1e-6),
        a covariance that is not symmetric positive semi-definite, or a home pose or robot
        that is not the cell's.
    """
    source = str(path)
    record_read(path, "the registration")
    try:
        with open(path, encoding="utf-8") as file:
            data = json.load(file)
        entry = data["frames"][name]
        rotation = np.array(entry["rotation"], dtype=float)
        translation = np.array(entry["translation_mm"], dtype=float) * MM
        rotation_cov = np.array(entry["rotation_cov_mrad2"], dtype=float) * 1e-6
        translation_cov = np.array(entry["translation_cov_mm2"], dtype=float) * MM**2
    except OSError as error:
        raise InputError(f"cannot read the registration ({error.strerror})", source=source) from None
    except (ValueError, KeyError, TypeError) as error:
        lacking = _lacking(data, name) if isinstance(error, KeyError) else None
        raise InputError(lacking or f"expected a registration file from `bayescal axes -o` with a '{name}' frame "
                         f"(problem: {type(error).__name__} {error})", source=source) from None
    shapes = rotation.shape == (3, 3) and translation.shape == (3,) and rotation_cov.shape == translation_cov.shape == (3, 3)
    if not shapes or not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
        raise InputError(f"the '{name}' frame's rotation is not a 3×3 rotation matrix, or its translation not 3 numbers",
                         source=source)
    for key, matrix, unit in (("rotation_cov_mrad2", rotation_cov * 1e6, "mrad²"), ("translation_cov_mm2", translation_cov / MM**2, "mm²")):
        reason = _covariance_violation(matrix, unit)
        if reason is not None:
            raise InputError(f"{reason}: not a covariance, and not what `bayescal axes -o` writes", source=source,
                             column=f"frames.{name}.{key}")
    _check_home(data, cell, source)
    return Frame(name, rotation, translation, rotation_cov, translation_cov, str(entry.get("from_nominal", "")))


def _lacking(data, name: str) -> str | None:
    """Why a registration `bayescal axes -o` wrote has no frame ``name``, in one line; None when it is not such a file."""
    if not isinstance(data, dict) or not isinstance(data.get("frames"), dict) or not isinstance(data.get("axes"), dict):
        return None
    fitted = sorted(int(j) for j in data["axes"] if str(j).isdigit())
    lacking = [j for j in (1, 2) if j not in fitted]
    sweep = f"sweep joint{'s' if len(lacking) > 1 else ''} {' and '.join(map(str, lacking))}" if lacking else "sweep joints 1 and 2"
    holds = ("it holds no axis" if not fitted else f"it holds the axis of joint {fitted[0]} only" if len(fitted) == 1
             else f"it holds the axes of joints {', '.join(map(str, fitted))} only")
    return f"no {name} frame: {sweep} ({holds}; the {name} frame is built from the axes of joints 1 and 2)"


_COVARIANCE_TOLERANCE = 1e-9
"""Asymmetry and negative eigenvalue a covariance may show, as a fraction of its largest entry: room for the
arithmetic's rounding (1e-16).  Measured on two registrations of simulated KR-270 sweeps written by ``bayescal axes -o``:
all eight covariances exactly symmetric, their smallest eigenvalue 0.009 to 0.33 of the largest entry."""


def _covariance_violation(matrix: np.ndarray, unit: str) -> str | None:
    """Why the 3×3 ``matrix`` (in ``unit``) is not a covariance, or ``None``."""
    if not np.all(np.isfinite(matrix)):
        return "a value that is not a finite number"
    scale = float(np.max(np.abs(matrix)))
    if np.max(np.abs(matrix - matrix.T), initial=0.0) > _COVARIANCE_TOLERANCE * scale:
        return "a matrix that is not symmetric"
    smallest = float(np.linalg.eigvalsh((matrix + matrix.T) / 2).min())
    if smallest < -_COVARIANCE_TOLERANCE * scale:
        return f"a negative variance (eigenvalue {smallest:.3g} {unit})"
    return None


def _check_home(data: dict, cell: Cell | None, source: str) -> None:
    """The file's home pose: a list of joint angles; with ``cell``, one per joint of its robot, within their limits, of its robot."""
    home = data.get("home_deg")
    ok = isinstance(home, list) and home and all(not isinstance(v, bool) and isinstance(v, (int, float)) and np.isfinite(v) for v in home)
    if not ok:
        raise InputError(f"expected home_deg, the sweeps' home pose as a list of joint angles in deg, got {home!r}: "
                         "the file is not a registration `bayescal axes -o` wrote", source=source, column="home_deg")
    if cell is None:
        return
    robot = cell.robot
    made_for = data.get("robot")
    if made_for and made_for != robot.model.name:
        raise InputError(f"made for the robot '{made_for}', but the robot of {cell.source} is '{robot.model.name}' ({robot.source})",
                         source=source, column="robot")
    if len(home) != robot.nq:
        raise InputError(f"the home pose has {len(home)} joint angles, but the robot of {cell.source} has {robot.nq} joints: "
                         "a registration of another robot?", source=source, column="home_deg")
    if not robot.prismatic.any():
        try:
            robot.check_limits(np.array(home, dtype=float) * DEG)
        except InputError as error:
            raise InputError(f"the home pose's {error.what} ({robot.source}): a registration of another robot?",
                             source=source, column="home_deg") from None
