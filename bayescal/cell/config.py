"""The calibration cell: a robot, its joint and compensator stiffness, the tool, the tracker.

A cell is described by a TOML file whose keys carry their units (schema in
``docs/twin.md``); :func:`load_cell` reads it and converts everything to SI.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from xml.etree import ElementTree
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.cell.cellfile import CellFileReader, read_cell_file
from bayescal.cell.joints import DEFAULT_COMPENSATED_JOINT, per_joint, read_compensator, reference_file
from bayescal.robot.compensator import Compensator
from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.kinematics import Robot
from bayescal.cell.loading import DIRECTIONS, MAX_LOAD_ARM, Loading
from bayescal.cell.plausible import MIN_LOAD_FRACTION, OVERLOAD_FACTOR, couple_limit_violation, force_limit_violation, mass_range_violation
from bayescal.cell.tracker import TrackerNoise
from bayescal.units import DEG, MM, UM, UM_PER_N, URAD_PER_NM

__all__ = ["Cell", "DesignLimits", "load_cell", "OVERLOAD_FACTOR", "MIN_LOAD_FRACTION", "DEFAULT_COMPLIANCE_LOG_SD"]

DEFAULT_COMPLIANCE_LOG_SD = 0.5
"""Prior sd of the log of a joint compliance a campaign cannot identify, when the cell gives none
(``[joints] k_log_sd``).  An ASSUMPTION, not a measurement: the cell's value may be off by a factor
``exp(±3 × 0.5)``, 0.22 to 4.5, at ±3σ, which spans the spread of the KR-270's identified compliances
about their mean within each group of joints (Klimchik et al., Table IV: k2 0.302, k3 0.406; k4..k6
2.4-3.3 μrad/(N·m)); the KR-270's k1 is itself an estimate (``data/kr270.toml``)."""

MAX_COMPLIANCE_LOG_SD = 3.0
"""Largest accepted ``k_log_sd``: a factor exp(9), about 8000, at ±3σ, beyond which the cell's value says nothing;
a relative sd in percent (50 for 0.5) lies far above it."""

@dataclass(frozen=True)
class DesignLimits:
    """What the cell file's optional ``[design]`` table says of campaigns; ``None`` leaves the designer's default.

    Attributes
    ----------
    mass_range : tuple of float or None
        ``(low, high)`` masses (kg) that may hang at the load point (``mass_kg``).
    acceptance : float or None
        Largest incidence angle on a marker, rad (``acceptance_deg``, in (0, 90] deg).
    floor_z : float or None
        Floor height in the robot's base frame, m (``floor_z_mm``).
    hanging_clearance : float or None
        Height the load point keeps above the floor, m (``hanging_clearance_mm``).
    """

    mass_range: tuple[float, float] | None = None
    acceptance: float | None = None
    floor_z: float | None = None
    hanging_clearance: float | None = None


@dataclass(frozen=True, eq=False)
class Cell:
    """Everything the digital twin and the identification need to know about a cell, in SI.

    Attributes
    ----------
    robot : Robot
    compliances : numpy.ndarray
        (nq,) joint compliances, rad/(N·m) for a revolute joint and m/N for a prismatic
        one; the compensated joint's excludes the compensator.
    compensator : Compensator or None
        The spring compensator, on the joint :attr:`compensated_joint`.
    load_point : numpy.ndarray
        (3,) where loads hang on the tool, flange frame, m.
    markers : dict of str to numpy.ndarray
        Tracker markers on the tool, flange frame, m.
    tracker : TrackerNoise
    load_mass : float
        Load (kg) for plans without a ``load_kg`` column.
    gravity : float
        Gravitational acceleration (m/s²) that turns load masses into forces.
    test_q : numpy.ndarray
        (nq,) test pose, rad (m for a prismatic joint).
    test_wrench : numpy.ndarray
        (6,) wrench at the test pose, ``[f (N); m (N·m)]`` at the flange origin, base axes.
    test_point : numpy.ndarray
        (3,) the tool point whose accuracy matters at the test pose, flange frame, m.
    source : str
        The TOML file.
    payload_kg : float or None
        The robot's rated payload, kg (``robot.payload_kg``), when the file gives it.
    tcp : numpy.ndarray or None
        (3,) the machining tool's point in the flange frame, m (``tool.tcp_mm``); ``None``
        when the file does not give it (:attr:`tool_point` then falls back to the test pose's point).
    design : DesignLimits
        The ``[design]`` table: what campaigns of this cell may load and where they must keep clear.
    loading : Loading
        What the end-effector can apply (``[load] directions``, ``force_max_N``, ``couple_max_Nm``).
    compliance_log_sd : float
        Standard deviation of the log of a joint compliance the campaign cannot identify
        (``[joints] k_log_sd``, default :data:`DEFAULT_COMPLIANCE_LOG_SD`): the prior its
        draws come from wherever an error is predicted (calibrate, plan, compensate, the review).
    compliance_log_sd_source : str
        Where :attr:`compliance_log_sd` comes from: the cell file's key or the default.
    reference : pathlib.Path or None
        Published results of this robot to set beside ours (``robot.reference_csv``, the
        format of ``data/paper_reference.csv``); ``None``: no comparison is shown.
    compensator_joint : int
        Index (0-based) of the joint the compensator acts on (``[compensator] joint``, 1-based,
        default 2); meaningless without a compensator (read :attr:`compensated_joint`).
    """

    robot: Robot
    compliances: np.ndarray
    compensator: Compensator | None
    load_point: np.ndarray
    markers: dict[str, np.ndarray]
    tracker: TrackerNoise
    load_mass: float
    gravity: float
    test_q: np.ndarray
    test_wrench: np.ndarray
    test_point: np.ndarray
    source: str
    payload_kg: float | None = None
    design: DesignLimits = DesignLimits()
    tcp: np.ndarray | None = None
    loading: Loading = Loading()
    compensator_joint: int = DEFAULT_COMPENSATED_JOINT
    reference: Path | None = None
    compliance_log_sd: float = DEFAULT_COMPLIANCE_LOG_SD
    compliance_log_sd_source: str = "default"

    @property
    def tool_point(self) -> np.ndarray:
        """(3,) the machining tool's point in the flange frame, m: ``tool.tcp_mm``, else ``test_pose.point_mm``."""
        return self.test_point if self.tcp is None else self.tcp

    @property
    def compensated_joint(self) -> int | None:
        """Index (0-based) of the joint that carries the compensator, or ``None`` when the cell has none."""
        return None if self.compensator is None else self.compensator_joint

    @property
    def plan_joint(self) -> int:
        """Index (0-based) of the joint whose angles group a campaign's configurations.

        The compensated joint, whose compliance the identification takes per angle; without
        a compensator the same default joint, kept so that plans keep their structure.
        """
        return min(self.compensator_joint, self.robot.nq - 1)

    @property
    def capacity_weight(self) -> float:
        """Weight (N) of the larger of the rated payload and the calibration load: the scale of plausible loads."""
        return max(self.payload_kg or 0.0, self.load_mass) * self.gravity

    @property
    def max_force(self) -> float:
        """Largest plausible static load force on the arm, N (:data:`OVERLOAD_FACTOR` times :attr:`capacity_weight`)."""
        return OVERLOAD_FACTOR * self.capacity_weight

    def load_wrench(self, q, mass: float) -> np.ndarray:
        """(6,) wrench at the flange origin (base axes) of ``mass`` kg hanging at the load point with the arm at ``q``."""
        return self.wrench(q, np.array([0.0, 0.0, -mass * self.gravity]))

    def wrench(self, q, force, couple=None) -> np.ndarray:
        """(6,) wrench at the flange origin (base axes) of ``force`` (3,) N through the load point and ``couple`` (3,) N·m, base axes."""
        force = np.asarray(force, dtype=float).reshape(3)
        couple = np.zeros(3) if couple is None else np.asarray(couple, dtype=float).reshape(3)
        rotation, _ = self.robot.flange_pose(q)
        return np.concatenate([force, np.cross(rotation @ self.load_point, force) + couple])


def _check_urdf_xml(urdf: Path, cell_file: Path) -> None:
    """Reject a URDF that is not XML with a ``<robot>`` root before the URDF parser prints its own lines to stderr."""
    if urdf.is_dir():
        raise InputError("is a folder; expected a URDF file", source=urdf)
    if not urdf.is_file():
        return  # Robot.from_urdf names the missing file
    record_read(urdf, f"the URDF the cell {cell_file} points to")
    try:
        root = ElementTree.parse(urdf).getroot()
    except ElementTree.ParseError as exc:
        raise InputError(f"not a URDF: not valid XML ({exc.msg})", source=urdf, line=exc.position[0]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the URDF ({type(exc).__name__})", source=urdf) from None
    if root.tag != "robot":
        raise InputError(f"not a URDF: the root element is <{root.tag}>, expected <robot>", source=urdf, line=1)


def _design_limits(reader: CellFileReader) -> DesignLimits:
    table = reader.table("design", required=False)
    if table is None:
        return DesignLimits()

    def optional(key: str, unit: str, scale: float) -> float | None:
        return reader.number("design", key, unit=unit) * scale if key in table else None

    mass_range = None
    if "mass_kg" in table:
        low, high = reader.vector("design", "mass_kg", 2, unit="kg [low, high]")
        mass_range = (float(low), float(high))
    acceptance = optional("acceptance_deg", "deg", 1.0)
    if acceptance is not None and not 0 < acceptance <= 90:
        reader.fail(f"expected an angle in deg in (0, 90], got {acceptance:g}", "design", "acceptance_deg")
    return DesignLimits(
        mass_range=mass_range,
        acceptance=None if acceptance is None else acceptance * DEG,
        floor_z=optional("floor_z_mm", "mm", MM),
        hanging_clearance=optional("hanging_clearance_mm", "mm", MM),
    )


def _loading(reader: CellFileReader) -> Loading:
    table = reader.table("load")
    directions = reader.text("load", "directions", default="down")
    if directions not in DIRECTIONS:
        reader.fail(f"expected \"down\" (hanging masses) or \"any\" (forces in any direction), got {directions!r}", "load", "directions")
    force_max = reader.number("load", "force_max_N", unit="N", positive=True) if "force_max_N" in table else None
    if directions == "any" and force_max is None:
        reader.fail('missing key \'force_max_N\' (eq 41\'s F_max in N), required with directions = "any"', "load")
    couple_max = reader.number("load", "couple_max_Nm", unit="N·m", non_negative=True, default=0.0)
    return Loading(directions=directions, force_max=force_max, couple_max=couple_max)
def _read_robot(reader: CellFileReader, file: Path) -> Robot:
    """The ``[robot]`` table: the URDF reduced to the named chain, other joints locked at their values."""
    urdf = file.parent / reader.text("robot", "urdf")
    flange = reader.text("robot", "flange", default="flange")
    table = reader.table("robot")
    joints = None
    if "joints" in table:
        joints = table["joints"]
        if not isinstance(joints, list) or not joints or not all(isinstance(name, str) and name for name in joints):
            reader.fail(f"expected a list of joint names from the base to the flange, got {joints!r}", "robot", "joints")
    locked: dict[str, tuple[float, str]] = {}
    for key, scale, unit, kind in (("locked_deg", DEG, "deg", "revolute"), ("locked_mm", MM, "mm", "prismatic")):
        values = table.get(key, {})
        ok = isinstance(values, Mapping) and all(not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) for v in values.values())
        if not ok:
            reader.fail(f"expected a table of joint names and positions in {unit}, e.g. {{ finger = 0 }}, got {values!r}", "robot", key)
        locked |= {str(name): (float(value) * scale, kind) for name, value in values.items()}
    _check_urdf_xml(urdf, file)
    try:
        robot = Robot.from_urdf(urdf, flange=flange, joints=joints, locked=locked)
    except InputError as error:
        key = "flange" if error.what.startswith("the model has no frame") else (error.column or "robot.urdf").split(".")[-1]
        reader.fail(f"{error.what} ({urdf})", "robot", key)
    return robot


def load_cell(path: str | PathLike[str]) -> Cell:
    """Read a cell TOML file (schema in ``docs/twin.md``) and convert it to SI.

    Raises
    ------
    InputError
        Naming the file, the line and the key of a missing or malformed entry,
        an unreadable URDF, or joint compliances that do not match the robot.
    """
    source = str(path)
    file = Path(path)
    reader = read_cell_file(file)

    robot = _read_robot(reader, file)
    payload = None
    if "payload_kg" in reader.table("robot"):
        payload = reader.number("robot", "payload_kg", unit="kg", positive=True)

    compliances, log_sd = _read_compliances(reader, robot)
    compensator, compensator_joint = read_compensator(reader, robot)

    load_point, markers = _read_tool(reader)
    tracker = _read_tracker(reader)

    load_mass = reader.number("load", "mass_kg", unit="kg", positive=True)
    robot = _with_tool_weight(reader, robot, max(payload or 0.0, load_mass))
    gravity = reader.number("load", "gravity_m_per_s2", unit="m/s²", positive=True, default=9.80665)

    test_q = _read_test_pose_q(reader, robot)
    test_wrench = reader.vector("test_pose", "wrench_N_Nm", 6, unit="N and N·m")
    cell = Cell(
        design=_design_limits(reader),
        loading=_loading(reader),
        robot=robot,
        compliances=compliances,
        compensator=compensator,
        load_point=load_point,
        markers=markers,
        tracker=tracker,
        load_mass=load_mass,
        gravity=gravity,
        test_q=test_q,
        test_wrench=test_wrench,
        test_point=reader.vector("test_pose", "point_mm", 3, unit="mm") * MM,
        source=source,
        payload_kg=payload,
        tcp=reader.vector("tool", "tcp_mm", 3, unit="mm") * MM if "tcp_mm" in reader.table("tool") else None,
        compensator_joint=compensator_joint,
        reference=reference_file(reader, file),
        compliance_log_sd=log_sd,
        compliance_log_sd_source=f"{source} [joints] k_log_sd" if "k_log_sd" in reader.table("joints") else "default",
    )
    _check_test_force(reader, cell)
    _check_loads(reader, cell)
    return cell


def _read_test_pose_q(reader: CellFileReader, robot) -> np.ndarray:
    """The test pose's joints ``(nq,)`` (SI), within the robot's limits."""
    test_q = per_joint(reader, robot, "test_pose", ("q_deg", "q_mm"), (DEG, MM))
    try:
        robot.check_limits(test_q)
    except InputError as error:
        reader.fail(error.what, "test_pose", "q_mm" if error.column.endswith("_mm") else "q_deg")
    return test_q


def _check_test_force(reader: CellFileReader, cell: Cell) -> None:
    """The test pose's force is one the robot can plausibly hold (else the wrench is likely in another unit)."""
    force = float(np.linalg.norm(cell.test_wrench[:3]))
    if force > cell.max_force:
        reader.fail(
            f"a force of {force:.4g} N is more than the {cell.max_force:.0f} N the robot can plausibly hold "
            f"({OVERLOAD_FACTOR:g} x the weight of {cell.capacity_weight / cell.gravity:g} kg): is the wrench in another unit?",
            "test_pose",
            "wrench_N_Nm",
        )


def _read_compliances(reader: CellFileReader, robot) -> tuple[np.ndarray, float]:
    """The ``[joints]`` compliances ``(nq,)`` (SI) and the log-sd of their prior."""
    compliances = per_joint(reader, robot, "joints", ("k_urad_per_Nm", "k_um_per_N"), (URAD_PER_NM, UM_PER_N))
    if np.any(compliances <= 0):
        reader.fail("expected positive joint compliances in μrad/(N·m) (revolute) and μm/N (prismatic)", "joints")
    log_sd = reader.number("joints", "k_log_sd", unit="log units", positive=True, default=DEFAULT_COMPLIANCE_LOG_SD)
    if log_sd > MAX_COMPLIANCE_LOG_SD:
        reader.fail(
            f"expected a log-sd of at most {MAX_COMPLIANCE_LOG_SD:g} (a factor exp(3 × {MAX_COMPLIANCE_LOG_SD:g}) at ±3σ), "
            f"got {log_sd:g}: is it a relative sd in % or a compliance?",
            "joints",
            "k_log_sd",
        )
    return compliances, log_sd


def _check_loads(reader: CellFileReader, cell: Cell) -> None:
    """Hold the cell's loads to the rules the options are held to (:mod:`bayescal.cell.plausible`), naming the key."""
    capacity_kg = cell.capacity_weight / cell.gravity
    checks = []
    if cell.payload_kg is not None:
        # The capacity counts the calibration load itself, so that load is held to the rated payload's bounds.
        checks.append(("load", "mass_kg", mass_range_violation(cell.load_mass, cell.load_mass, cell.payload_kg)))
    if cell.design.mass_range is not None:
        checks.append(("design", "mass_kg", mass_range_violation(*cell.design.mass_range, capacity_kg)))
    if cell.loading.force_max is not None:
        checks.append(("load", "force_max_N", force_limit_violation(cell.loading.force_max, capacity_kg, cell.gravity)))
    force = cell.loading.force_max or 0.0
    checks.append(("load", "couple_max_Nm", couple_limit_violation(cell.loading.couple_max, force, capacity_kg, cell.gravity)))
    for table, key, reason in checks:
        if reason is not None:
            reader.fail(reason, table, key)


def _read_tool(reader: CellFileReader) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The ``[tool]`` table's load point (3,) and markers (3,) each, flange frame, m."""
    load_point = reader.vector("tool", "load_point_mm", 3, unit="mm") * MM
    marker_table = reader.table("tool.markers_mm")
    if not marker_table:
        reader.fail("expected at least one marker, e.g. M1 = [x, y, z]", "tool.markers_mm")
    markers = {
        str(name): reader.vector_value(value, 3, "mm", "tool.markers_mm", str(name)) * MM
        for name, value in marker_table.items()
    }
    _check_reach(reader, load_point, markers)
    return load_point, markers


def _with_tool_weight(reader: CellFileReader, robot: Robot, capacity_kg: float) -> Robot:
    """The robot carrying the ``[tool]`` table's weighed tool (``mass_kg`` at ``com_mm``); itself without one."""
    table = reader.table("tool")
    if "com_mm" in table and "mass_kg" not in table:
        reader.fail("a centre of mass without the tool's mass: give mass_kg (kg) with com_mm", "tool", "com_mm")
    mass = reader.number("tool", "mass_kg", unit="kg", non_negative=True, default=0.0)
    if mass > capacity_kg:
        reader.fail(f"a tool of {mass:g} kg is heavier than the {capacity_kg:g} kg the robot carries (robot.payload_kg, "
                    "load.mass_kg): is it in g?", "tool", "mass_kg")
    if mass == 0.0:
        return robot
    if "com_mm" not in table:
        reader.fail("missing key 'com_mm' (the tool's centre of mass, flange frame, a list of 3 numbers in mm), "
                    "required with mass_kg", "tool")
    centre = reader.vector("tool", "com_mm", 3, unit="mm") * MM
    _check_reach(reader, centre, {}, key="com_mm")
    return robot.with_tool(mass, centre)


def _read_tracker(reader: CellFileReader) -> TrackerNoise:
    """The ``[tracker]`` table: the tracker's position (base frame, m) and noise model."""
    noise = {
        "U0": reader.number("tracker", "U0_um", unit="μm", default=15.0) * UM,
        "U1": reader.number("tracker", "U1_um_per_m", unit="μm/m", default=6.0) * UM,
        "factor": reader.number("tracker", "factor", unit="a fraction", default=0.8),
    }
    if min(noise.values()) < 0:
        reader.fail("the noise parameters U0_um, U1_um_per_m and factor must not be negative", "tracker")
    tracker = TrackerNoise(position=reader.vector("tracker", "position_mm", 3, unit="mm") * MM, **noise)
    return tracker


def _check_reach(reader, load_point: np.ndarray, markers: dict[str, np.ndarray], key: str = "load_point_mm") -> None:
    """Refuse a load point (or the tool's centre of mass, ``key``) or a marker farther from the flange than any tool reaches."""
    for name, point in [(key, load_point)] + list(markers.items()):
        distance = float(np.linalg.norm(point))
        if distance > MAX_LOAD_ARM:
            table = "tool" if name == key else "tool.markers_mm"
            reader.fail(
                f"a point {distance / MM:.6g} mm from the flange is beyond any tool ({MAX_LOAD_ARM / MM:g} mm); is it in μm instead of mm?",
                table,
                name,
            )
