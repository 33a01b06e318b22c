"""A cell of measured points: a robot tree, the markers on its links, the base in the tracker frame, the priors.

Where an elastostatic cell (:mod:`bayescal.cell.config`) carries a tool with
markers on one flange and loads hung from it, a cell of measured points says
which link each tracked marker sits on (both hands of a humanoid, several
reflectors on one tool), how the controller's commanded joints map onto the
URDF's joints (a coupled joint follows a linear law of others), where the robot's
base stands in the tracker's frame (a first guess: the calibration identifies it)
and the prior sds of every parameter the kinematic calibration identifies.  The
file's tables are ``[robot]`` (``urdf``, ``joints``: the commanded joints in the
positions file's order, ``[robot.coupled]``), ``[markers.NAME]`` (``link``,
``position_mm``), ``[base]``, ``[frames]`` (``free``: joints whose placement is
unknown, e.g. a shoulder's mount), ``[tracker]`` and ``[priors]``
(``docs/kinematics.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path

import numpy as np
import pinocchio as pin

from bayescal.cell.cellfile import CellFileReader, read_cell_file
from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.kinematics.axes import joints_about_z
from bayescal.kinematics.tree import BatchedTree
from bayescal.output import record_read
from bayescal.units import DEG, MM, UM, URAD_PER_NM

__all__ = ["Marker", "PointsCell", "Priors", "load_points_cell"]


@dataclass(frozen=True)
class Priors:
    """Prior sds (SI) of the kinematic calibration's parameters, each from the cell's ``[priors]`` or its default.

    The defaults are wide: they say what a nominal model and a rough placement
    leave open, and the data, not the prior, should set every identifiable value.
    """

    base_translation: float = 300 * MM
    base_rotation: float = 15 * DEG
    frame_translation: float = 100 * MM
    frame_rotation: float = 30 * DEG
    marker: float = 50 * MM
    offset: float = 1.5 * DEG
    length: float = 10 * MM
    twist: float = 1.5 * DEG
    joint_compliance: float = 1000 * URAD_PER_NM
    transversal_compliance: float = 1000 * URAD_PER_NM
    mass_fraction: float = 0.5
    com: float = 100 * MM
    # The base's (extension ``base-elastic``): under 100 N·m a turn of 0.1 rad and a shift of 0.1 m, far beyond any
    # platform (Justin's: tens of μrad/(N·m) and μm/(N·m)).
    base_compliance: float = 1000 * URAD_PER_NM
    base_shift: float = 1000 * UM


_PRIOR_KEYS = {
    "base_sd_mm": ("base_translation", MM, "mm"),
    "base_sd_deg": ("base_rotation", DEG, "deg"),
    "frame_sd_mm": ("frame_translation", MM, "mm"),
    "frame_sd_deg": ("frame_rotation", DEG, "deg"),
    "marker_sd_mm": ("marker", MM, "mm"),
    "offset_sd_deg": ("offset", DEG, "deg"),
    "length_sd_mm": ("length", MM, "mm"),
    "twist_sd_deg": ("twist", DEG, "deg"),
    "joint_compliance_sd_urad_per_Nm": ("joint_compliance", URAD_PER_NM, "μrad/(N·m)"),
    "transversal_compliance_sd_urad_per_Nm": ("transversal_compliance", URAD_PER_NM, "μrad/(N·m)"),
    "mass_sd_fraction": ("mass_fraction", 1.0, "a fraction of the URDF's mass"),
    "com_sd_mm": ("com", MM, "mm"),
    "base_compliance_sd_urad_per_Nm": ("base_compliance", URAD_PER_NM, "μrad/(N·m)"),
    "base_shift_sd_um_per_Nm": ("base_shift", UM, "μm/(N·m)"),
}
"""Each ``[priors]`` key: the :class:`Priors` field it sets, its unit's SI value and the unit's name."""


@dataclass(frozen=True)
class Marker:
    """A tracked point on a link: its name, the link's joint index in the model and its position in the link frame (m)."""

    name: str
    joint: int
    position: np.ndarray


@dataclass(frozen=True)
class PointsCell:
    """A robot tree with markers on its links, measured by a tracker (SI inside).

    Attributes
    ----------
    tree : BatchedTree
        The URDF's joints, placements and masses.
    commanded : tuple of str
        The commanded joints, in the positions file's column order (``q1_deg`` first).
    coupling : numpy.ndarray
        ``(nq, n_commanded)`` map from commanded joint angles to the model's ``q`` (a
        commanded joint's own column holds 1; a coupled joint's row its law).
    markers : tuple of Marker
    base : pinocchio.SE3
        First guess of the robot's base in the tracker frame.
    gravity : numpy.ndarray
        ``(3,)`` gravity in the tracker frame, m/s² (along -z).
    free_frames : tuple of int
        Joints whose placement is unknown: identified as a whole 6-D frame.
    tracker : TrackerNoise
    priors : Priors
    source : str
    """

    tree: BatchedTree
    commanded: tuple[str, ...]
    coupling: np.ndarray
    markers: tuple[Marker, ...]
    base: pin.SE3
    gravity: np.ndarray
    free_frames: tuple[int, ...]
    tracker: TrackerNoise
    priors: Priors = field(default_factory=Priors)
    source: str = ""

    @property
    def marker_names(self) -> tuple[str, ...]:
        return tuple(marker.name for marker in self.markers)

    @property
    def joint_columns(self) -> tuple[str, ...]:
        """The positions file's joint columns: ``q1_deg`` … ``qn_deg``."""
        return tuple(f"q{i + 1}_deg" for i in range(len(self.commanded)))

    @property
    def moving(self) -> tuple[int, ...]:
        """The model joints that move in some configuration (commanded or coupled), in model order."""
        rows = np.flatnonzero(np.any(self.coupling != 0, axis=1))
        return tuple(j for j in range(1, self.tree.nj) if self.tree.idx_q[j] in rows)

    def model_configuration(self, commanded: np.ndarray) -> np.ndarray:
        """``(N, nq)`` the model's joint angles (rad) of ``(N, n_commanded)`` commanded ones."""
        return np.asarray(commanded, dtype=float) @ self.coupling.T


def load_points_cell(path: str | PathLike[str]) -> PointsCell:
    """Read a cell of measured points and convert it to SI.

    Raises
    ------
    InputError
        Naming the file, the line and the key of a missing or malformed entry: an
        unknown joint or link, a coupled joint that is also commanded, a marker table
        without its link or position.
    """
    file = Path(path)
    reader = read_cell_file(file)
    source = str(path)
    urdf = file.parent / reader.text("robot", "urdf")
    if not urdf.is_file():
        reader.fail(f"URDF file not found: {urdf}", "robot", "urdf")
    record_read(urdf, f"the URDF the cell {source} points to")
    try:
        model = pin.buildModelFromUrdf(str(urdf))
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"cannot read the URDF ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})", source=str(urdf)) from None
    # An industrial URDF turns its joints about x, y or -z: the calibration's corrections live where each axis is z.
    model = joints_about_z(model)
    tree = BatchedTree(model, source=str(urdf))
    commanded = _commanded(reader, tree)
    coupling = _coupling(reader, tree, commanded)
    markers = _markers(reader, model)
    base = reader.table("base")
    rpy = reader.vector("base", "rpy_deg", 3, unit="deg") * DEG if "rpy_deg" in base else np.zeros(3)
    placement = pin.SE3(pin.rpy.rpyToMatrix(*rpy), reader.vector("base", "position_mm", 3, unit="mm") * MM)
    gravity = reader.number("base", "gravity_m_per_s2", unit="m/s²", positive=True, default=9.80665)
    free = _free_frames(reader, tree)
    tracker = reader.table("tracker")
    noise = TrackerNoise(
        position=np.zeros(3),
        U0=reader.number("tracker", "U0_um", unit="μm", non_negative=True) * 1e-6,
        U1=reader.number("tracker", "U1_um_per_m", unit="μm/m", non_negative=True, default=0.0) * 1e-6,
        factor=reader.number("tracker", "factor", unit="a fraction", positive=True, default=1.0),
    )
    if "position_mm" in tracker:
        noise = TrackerNoise(position=reader.vector("tracker", "position_mm", 3, unit="mm") * MM, U0=noise.U0, U1=noise.U1, factor=noise.factor)
    return PointsCell(
        tree=tree,
        commanded=commanded,
        coupling=coupling,
        markers=markers,
        base=placement,
        gravity=np.array([0.0, 0.0, -gravity]),
        free_frames=free,
        tracker=noise,
        priors=_priors(reader),
        source=source,
    )


def _joint_index(reader: CellFileReader, tree: BatchedTree, name: object, table: str, key: str) -> int:
    if not isinstance(name, str) or name not in tree.names[1:]:
        reader.fail(f"the URDF has no joint {name!r}; its joints are {', '.join(tree.names[1:])}", table, key)
    return tree.names.index(name)


def _commanded(reader: CellFileReader, tree: BatchedTree) -> tuple[str, ...]:
    names = reader.table("robot").get("joints")
    if not isinstance(names, list) or not names:
        reader.fail("expected the list of commanded joints, in the positions file's column order", "robot", "joints")
    for name in names:
        _joint_index(reader, tree, name, "robot", "joints")
    if len(set(names)) != len(names):
        reader.fail("list each commanded joint once", "robot", "joints")
    return tuple(names)


def _coupling(reader: CellFileReader, tree: BatchedTree, commanded: tuple[str, ...]) -> np.ndarray:
    """The map from commanded to model joint angles; a joint neither commanded nor coupled stays at 0."""
    coupling = np.zeros((tree.model.nq, len(commanded)))
    for column, name in enumerate(commanded):
        coupling[tree.idx_q[tree.names.index(name)], column] = 1.0
    laws = reader.table("robot.coupled", required=False) or {}
    for name, law in laws.items():
        joint = _joint_index(reader, tree, name, "robot.coupled", name)
        if name in commanded:
            reader.fail(f"joint '{name}' is commanded; a coupled joint follows the commanded ones", "robot.coupled", name)
        if not isinstance(law, dict) or not law:
            reader.fail("expected an inline table of commanded joints and their factors, e.g. { j2 = -1.0, j3 = -1.0 }", "robot.coupled", name)
        for other, factor in law.items():
            if other not in commanded:
                reader.fail(f"'{other}' is not a commanded joint ([robot] joints)", "robot.coupled", name)
            if isinstance(factor, bool) or not isinstance(factor, (int, float)) or not np.isfinite(factor):
                reader.fail(f"expected a number as the factor of '{other}', got {factor!r}", "robot.coupled", name)
            coupling[tree.idx_q[joint], commanded.index(other)] = float(factor)
    return coupling


def _markers(reader: CellFileReader, model: pin.Model) -> tuple[Marker, ...]:
    tables = reader.table("markers")
    if not tables:
        reader.fail("expected at least one [markers.NAME] table with its link and position_mm", "markers")
    markers = []
    for name, table in tables.items():
        where = f"markers.{name}"
        if not isinstance(table, dict):
            reader.fail("expected a table with 'link' and 'position_mm'", "markers", name)
        unknown = sorted(set(table) - {"link", "position_mm"})
        if unknown:
            reader.fail(f"unknown key '{unknown[0]}'; known keys: link, position_mm", where, unknown[0])
        link = reader.text(where, "link")
        if not model.existBodyName(link):
            bodies = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
            reader.fail(f"the URDF has no link '{link}'; its links are {', '.join(bodies)}", where, "link")
        frame = model.frames[model.getBodyId(link)]
        offset = reader.vector(where, "position_mm", 3, unit="mm") * MM
        # A link merged into its parent body by a fixed joint: the marker's place in the joint's frame.
        position = np.array(frame.placement.act(offset))
        markers.append(Marker(name=str(name), joint=int(frame.parentJoint), position=position))
    return tuple(markers)


def _free_frames(reader: CellFileReader, tree: BatchedTree) -> tuple[int, ...]:
    table = reader.table("frames", required=False) or {}
    names = table.get("free", [])
    if not isinstance(names, list):
        reader.fail("expected a list of joint names", "frames", "free")
    return tuple(_joint_index(reader, tree, name, "frames", "free") for name in names)


def _priors(reader: CellFileReader) -> Priors:
    table = reader.table("priors", required=False) or {}
    values = {}
    for key in table:
        name, scale, unit = _PRIOR_KEYS[key]
        values[name] = reader.number("priors", key, unit=unit, positive=True) * scale
    return Priors(**values)
