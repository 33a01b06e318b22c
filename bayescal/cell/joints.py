"""The cell file's keys that depend on the robot's joints: per-joint lists, the compensator's joint, published results.

A robot's joints are revolute (angles in deg, compliances in μrad/(N·m) at the edges)
or prismatic (positions in mm, compliances in μm/N); the cell lists each kind's values
in chain order under its own key.  These readers take the cell file's reader
(:class:`bayescal.cell.cellfile.CellFileReader`), which names the file, line and key of an error.
"""

from __future__ import annotations

from pathlib import Path
import numpy as np

from bayescal.cell.cellfile import COMPENSATOR_KEYS, CellFileReader
from bayescal.output import record_read
from bayescal.robot.kinds import DEFAULT_KIND, LAWS
from bayescal.robot.laws import CompensatorLaw
from bayescal.robot.kinematics import Robot
from bayescal.units import DEG, MM

__all__ = ["DEFAULT_COMPENSATED_JOINT", "per_joint", "read_compensator", "reference_file"]

DEFAULT_COMPENSATED_JOINT = 1
"""Index (0-based) of the compensated joint when ``[compensator]`` gives no ``joint``: A2, as on the KR-270."""


MAX_COMPENSATOR_LENGTH = 5.0
"""Longest (m) lever L or pivot offset a_x, a_y of a compensator: longer than any industrial arm's link
(ESTIMATE; the KR-270's are 0.18 and 0.70 m, Klimchik et al. Table II)."""


def reference_file(reader: CellFileReader, file: Path) -> Path | None:
    """The ``robot.reference_csv`` file of published results, or ``None`` without the key or the file.

    A cell file copied from ``data/kr270.toml`` to describe another robot keeps the key but
    not the KR-270's published table beside it: its results are then compared with nothing.
    """
    if "reference_csv" not in reader.table("robot"):
        return None
    path = file.parent / reader.text("robot", "reference_csv")
    if not path.is_file():
        return None
    # Read later (beside the results), but the cell's own: no output of a run on this cell may replace it.
    record_read(path, f"the reference table the cell {file} points to")
    return path


def per_joint(reader: CellFileReader, robot: Robot, table: str, keys: tuple[str, str], scales: tuple[float, float]) -> np.ndarray:
    """(nq,) values in SI from a list for the revolute joints and one for the prismatic joints, each in chain order."""
    values = np.empty(robot.nq)
    for key, scale, prismatic in zip(keys, scales, (False, True)):
        joints = np.flatnonzero(robot.prismatic == prismatic)
        unit = key.split("_", 1)[1]
        if joints.size == 0:
            if key in reader.table(table):
                reader.fail(f"the robot has no {'prismatic' if prismatic else 'revolute'} joint: remove '{key}'", table, key)
            continue
        names = ", ".join(robot.joint_names[j] for j in joints)
        values[joints] = reader.vector(table, key, joints.size, unit=f"{unit} for {names}") * scale
    return values


def read_compensator(reader: CellFileReader, robot: Robot) -> tuple[CompensatorLaw | None, int]:
    """The ``[compensator]`` table: the law of its ``kind`` (the spring of eqs 4-9 by default) and the (0-based)
    joint it acts on, or ``None``."""
    if reader.table("compensator", required=False) is None:
        return None, DEFAULT_COMPENSATED_JOINT
    table = reader.table("compensator")
    joint = DEFAULT_COMPENSATED_JOINT
    if "joint" in table:
        number = table["joint"]
        if isinstance(number, bool) or not isinstance(number, int) or not 1 <= number <= robot.nq:
            reader.fail(f"expected a joint number from 1 to {robot.nq} (1-based, base first), got {number!r}", "compensator", "joint")
        joint = number - 1
    elif robot.nq <= joint:
        reader.fail(f"the robot has {robot.nq} joint(s): give the compensated joint as joint = <1..{robot.nq}>", "compensator")
    if robot.prismatic[joint]:
        reader.fail(f"joint {joint + 1} ({robot.joint_names[joint]}) is prismatic: a compensator of eq 4's linkage turns a revolute joint", "compensator", "joint")
    law = _law(reader)
    values = {
        "L": reader.number("compensator", "L_mm", unit="mm", positive=True) * MM,
        "a_x": reader.number("compensator", "a_x_mm", unit="mm") * MM,
        "a_y": reader.number("compensator", "a_y_mm", unit="mm") * MM,
        "phi": reader.number("compensator", "phi_deg", unit="deg") * DEG,
    }
    for parameter in law.PARAMETERS + law.CONSTANTS:
        bound = {parameter.bound: True} if parameter.bound else {}
        values[parameter.name] = reader.number("compensator", parameter.key, unit=parameter.unit, **bound) * parameter.si_factor
    for name in ("L", "a_x", "a_y"):
        if abs(values[name]) > MAX_COMPENSATOR_LENGTH:
            reader.fail(
                f"{values[name] / MM:g} mm is longer than any compensator linkage ({MAX_COMPENSATOR_LENGTH / MM:g} mm); "
                "is it in μm instead of mm?",
                "compensator",
                f"{name}_mm",
            )
    try:
        return law(**values), joint
    except ValueError as exc:
        reader.fail(str(exc), "compensator")


def _law(reader: CellFileReader) -> type:
    """The law class the ``[compensator] kind`` names (:data:`~bayescal.robot.kinds.LAWS`)."""
    kind = reader.table("compensator").get("kind", DEFAULT_KIND)
    if kind not in LAWS:
        reader.fail(f"unknown compensator kind {kind!r}; expected one of {', '.join(sorted(LAWS))}", "compensator", "kind")
    law = LAWS[kind]
    own = COMPENSATOR_KEYS | {p.key for p in law.PARAMETERS + law.CONSTANTS}
    for key in reader.table("compensator"):
        if key not in own:
            reader.fail(f"not a key of a {kind!r} compensator (kind = {kind!r})", "compensator", key)
    return law
