"""The cell's URDF with a calibration's identified parameters, for the tools that read URDF, and their reader.

The URDF is the cell's file as it is, byte for byte, with additions that every
URDF reader other than this one ignores (Pinocchio's and ROS's parsers skip
elements they do not know, and the prefix is an XML namespace), and, for a
kinematic calibration, the identified joint placements in place of the nominal:

* the ``<origin>`` of each joint whose placement the calibration corrects,
  ``origin · exp(δ)`` at the posterior mean (:mod:`bayescal.kinematics.model`: the
  correction right-multiplies the joint's placement), written with 17 significant digits;

* ``xmlns:bayescal="urn:bayescal:urdf-extension:1"`` on ``<robot>``;
* before ``</robot>``, one ``<bayescal:calibration>`` element holding a
  ``<bayescal:compliance>`` per chain joint,
  ``joint``, ``mean_urad_per_Nm``, ``sd_urad_per_Nm`` (``mean_um_per_N``, ``sd_um_per_N`` for a
  prismatic joint) and ``identified`` (``false``: the campaign did not identify it, and the
  numbers are its prior's), and, for a cell with a compensator, a ``<bayescal:compensator>``
  with the mean and sd of the compensator law's parameters under their cell keys (``K_c_N_per_mm``,
  ``s0_mm`` for the spring), ``L``, ``a_x``, ``a_y`` (mm) and ``phi`` (deg).
  For a kinematic calibration the compliances are its joints' ``k_theta`` (posterior mean and
  sd of its Gaussian), identified when the data shrink the prior's sd by half.

Means and sds of an elastostatic calibration are over its draws (posterior draws;
prior draws for a parameter not identified).  Since the kinematics, masses and limits are the cell's
own, a cell may point its ``[robot] urdf`` at the written file and load the same robot.
"""

from __future__ import annotations

import re
from os import PathLike
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from bayescal.compensation.calibration import Calibration
from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.compensator import Compensator
from bayescal.robot.kinematics import Robot
from bayescal.units import DEG, MM

__all__ = ["NAMESPACE", "calibrated_urdf", "kinematic_urdf", "read_compliances"]

NAMESPACE = "urn:bayescal:urdf-extension:1"
"""The XML namespace of the extension elements (a name, not a location)."""

MICRO = 1e-6
"""μrad/(N·m) and μm/N per rad/(N·m) and m/N."""

_COMMENT = re.compile(r"<!--.*?-->", re.S)
_ROBOT = re.compile(r"<robot(?=[\s>/])")
_END = re.compile(r"</robot\s*>")


def _outside_comments(pattern: re.Pattern, text: str, last: bool = False):
    comments = [match.span() for match in _COMMENT.finditer(text)]
    found = [m for m in pattern.finditer(text) if not any(start <= m.start() < end for start, end in comments)]
    return (found[-1] if last else found[0]) if found else None


def calibrated_urdf(urdf_text: str, robot: Robot, calibration: Calibration, *, source: str = "") -> str:
    """The URDF text ``urdf_text`` of ``robot`` with ``calibration``'s compliances (and compensator) added.

    Parameters
    ----------
    urdf_text
        The cell's URDF, as read.
    robot
        The cell's robot (its chain joints name the compliances).
    calibration
        The calibration's draws.
    source
        The calibration file's name, recorded in the element.
    """
    mean, sd = calibration.own.mean(axis=0), calibration.own.std(axis=0, ddof=1)
    compliances = [
        (name, robot.prismatic[j], mean[j], sd[j], f"k{j + 1}" not in calibration.unidentified) for j, name in enumerate(robot.joint_names)
    ]
    extra = []
    if calibration.spring is not None:
        law = (calibration.law or Compensator).PARAMETERS
        values = {p.key: calibration.spring[:, i] / p.si_factor for i, p in enumerate(law)} | {
            "L_mm": calibration.geometry[:, 0] / MM, "a_x_mm": calibration.geometry[:, 1] / MM,
            "a_y_mm": calibration.geometry[:, 2] / MM, "phi_deg": calibration.geometry[:, 3] / DEG,
        }
        attributes = " ".join(f'{key}_mean="{v.mean():.6g}" {key}_sd="{v.std(ddof=1):.6g}"' for key, v in values.items())
        extra.append(f'    <bayescal:compensator joint="{_escape(robot.joint_names[calibration.compensated_joint])}" {attributes}/>')
    return _with_block(urdf_text, robot.source, compliances, extra, source, calibration.n_draws)


def _with_block(urdf_text: str, where, compliances, extra: list[str], source: str, draws: int | None) -> str:
    """``urdf_text`` with the namespace declared and the ``<bayescal:calibration>`` element before ``</robot>``."""
    start = _outside_comments(_ROBOT, urdf_text)
    end = _outside_comments(_END, urdf_text, last=True)
    if start is None or end is None:
        raise InputError("not a URDF: no <robot> … </robot> element", source=where)
    if "xmlns:bayescal" in urdf_text[start.start():urdf_text.index(">", start.end())]:
        raise InputError("the URDF carries a calibration already: export from the cell's own URDF", source=where)
    counted = "" if draws is None else f' draws="{draws}"'
    lines = [f'  <bayescal:calibration source="{_escape(source)}"{counted}>']
    for name, prismatic, mean, sd, identified in compliances:
        unit = "um_per_N" if prismatic else "urad_per_Nm"
        lines.append(
            f'    <bayescal:compliance joint="{_escape(name)}" mean_{unit}="{mean / MICRO:.6g}" sd_{unit}="{sd / MICRO:.6g}" '
            f'identified="{"true" if identified else "false"}"/>'
        )
    lines += extra + ["  </bayescal:calibration>"]
    head = urdf_text[: start.end()] + f' xmlns:bayescal="{NAMESPACE}"' + urdf_text[start.end(): end.start()]
    return head + "\n".join(lines) + "\n" + urdf_text[end.start():]


def kinematic_urdf(urdf_text: str, results, *, source: str = "") -> str:
    """The URDF text ``urdf_text`` of a points cell with a kinematic calibration's placements and compliances.

    Parameters
    ----------
    urdf_text
        The cell's URDF, as read.
    results
        A :class:`~bayescal.kinematics.results.KinematicResults` of that cell.
    source
        The calibration file's name, recorded in the element.
    """
    import pinocchio as pin

    from bayescal.kinematics.results import IDENTIFIED_RATIO

    model = results.model
    tree = model.cell.tree
    text = urdf_text
    for j, delta in model._corrections(results.mean).items():
        text = _with_origin(text, tree.names[j], pin.exp6(delta), tree.source)
    compliances = []
    for j in model.elastic:
        if 2 not in model.axes[j]:
            continue
        i = model.names.index(f"{tree.names[j]}.k_theta")
        compliances.append((tree.names[j], False, results.mean[i], results.sd[i], results.sd[i] / model.sd[i] < IDENTIFIED_RATIO))
    return _with_block(text, tree.source, compliances, [], source, None)


def _with_origin(text: str, joint: str, correction, where) -> str:
    """``text`` with joint ``joint``'s ``<origin>`` right-multiplied by ``correction`` (a ``pinocchio.SE3``).

    The URDF's origin, not Pinocchio's joint placement: the placement also holds the fixed joints
    Pinocchio merges before a joint, and the correction acts after them, on the joint's own origin.
    """
    import pinocchio as pin

    # The joint element, not a transmission's <joint name=…> reference: only the former has a type.
    match = re.search(rf'<joint\s(?=[^>]*\btype\s*=)[^>]*\bname\s*=\s*"{re.escape(joint)}"[^>]*>(.*?)</joint\s*>', text, re.S)
    if match is None:
        raise InputError(f"joint '{joint}' not found as <joint name=\"{joint}\"> … </joint>", source=where)
    body = match.group(1)
    found = re.search(r"<origin\b[^>]*/>|<origin\b[^>]*>.*?</origin\s*>", body, re.S)
    nominal = pin.SE3.Identity()
    if found:
        attributes = dict(re.findall(r'(xyz|rpy)\s*=\s*"([^"]*)"', found.group()))
        try:
            xyz_values = [float(v) for v in attributes.get("xyz", "0 0 0").split()]
            rpy_values = [float(v) for v in attributes.get("rpy", "0 0 0").split()]
        except ValueError:
            raise InputError(f"joint '{joint}': its <origin> is not three numbers xyz and rpy", source=where) from None
        if len(xyz_values) != 3 or len(rpy_values) != 3:
            raise InputError(f"joint '{joint}': its <origin> is not three numbers xyz and rpy", source=where)
        nominal = pin.SE3(pin.rpy.rpyToMatrix(np.array(rpy_values)), np.array(xyz_values))
    placement = nominal * correction
    xyz = " ".join(f"{v:.17g}" for v in placement.translation)
    rpy = " ".join(f"{v:.17g}" for v in pin.rpy.matrixToRpy(placement.rotation))
    origin = f'<origin xyz="{xyz}" rpy="{rpy}"/>'
    body = body[: found.start()] + origin + body[found.end():] if found else f"\n    {origin}" + body
    return text[: match.start(1)] + body + text[match.end(1):]


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")


def read_compliances(path: str | PathLike[str], robot: Robot) -> dict[str, dict]:
    """The compliances a calibrated URDF carries, by joint: ``{"mean", "sd"}`` (rad/(N·m) or m/N) and ``identified``.

    Raises
    ------
    InputError
        When the file has no calibration element, names a joint ``robot`` does not have, misses a
        joint of ``robot``, or holds a value that is not a number, or a negative sd (naming the file and the attribute).
    """
    source = str(path)
    record_read(path, "the calibrated URDF")
    try:
        root = ElementTree.parse(Path(path)).getroot()
    except ElementTree.ParseError as exc:
        raise InputError(f"not valid XML ({exc.msg})", source=source, line=exc.position[0]) from None
    block = root.find(f"{{{NAMESPACE}}}calibration")
    if block is None:
        raise InputError("no <bayescal:calibration> element: not a URDF written by `bayescal export`", source=source)
    out: dict[str, dict] = {}
    for element in block.findall(f"{{{NAMESPACE}}}compliance"):
        name = element.get("joint", "")
        if name not in robot.joint_names:
            raise InputError(f"compliance of joint '{name}', which the robot's chain does not have", source=source, column="joint")
        unit = "um_per_N" if robot.prismatic[robot.joint_names.index(name)] else "urad_per_Nm"
        values = {}
        for key in ("mean", "sd"):
            text = element.get(f"{key}_{unit}")
            try:
                value = float(text)
            except (TypeError, ValueError):
                raise InputError(f"joint {name}: expected a number in {key}_{unit}, got {text!r}", source=source, column=f"{key}_{unit}") from None
            # A Gaussian posterior's mean (a kinematic calibration's) may fall below zero for a compliance the data do
            # not identify; an sd may not.
            if not np.isfinite(value) or (key == "sd" and value < 0):
                raise InputError(f"joint {name}: expected a finite{' non-negative' if key == 'sd' else ''} {key}_{unit}, got {text}",
                                 source=source, column=f"{key}_{unit}")
            values[key] = value * MICRO
        out[name] = values | {"identified": element.get("identified") != "false"}
    missing = [name for name in robot.joint_names if name not in out]
    if missing:
        raise InputError(f"no compliance for joint{'s' if len(missing) > 1 else ''} {', '.join(missing)}", source=source)
    return out
