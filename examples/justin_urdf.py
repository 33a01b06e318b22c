"""Write ``data/robots/justin.urdf``: Agile Justin's upper body from the published modified-DH table.

Source of the geometry: the nominal DH table of the data set of Tenhumberg and
Bäuml, "Calibration of an Elastic Humanoid Upper Body and Efficient Compensation
for Motion Planning", IEEE-RAS Humanoids 2021 (arXiv 2311.08333), public
repository ``dlr-alr/dlr-elastic-calibration``.  Each column is the transform
Rx(α) Tx(r) Rz(θ + q) Tz(d) from its predecessor (modified, Craig, DH); the arms
and the head hang off torso frame 3.  What the table does not give is flagged:

* the shoulders' mounts on torso frame 3 (not in the table): the result of a
  frames-only fit to the data set started from mounts 0.25 m to each side along
  torso frame 3's z axis (``docs/kinematics.md``), rounded; the calibration
  identifies them again as free frames;
* every mass (the authors' come from CAD and are not published): ESTIMATES of the
  right order for arms of this size, each body's centre of mass halfway to the
  next joint; the calibration identifies masses and compliances together.

Run ``python examples/justin_urdf.py data/robots/justin.urdf``; the tests check that
the shipped file is this script's output.
"""

from __future__ import annotations

import math
import sys

import numpy as np

TORSO = [(0.1055, 0, 0, 0), (0, -90, 0, -90), (0, 0, 0.3, 0), (0, 0, 0.3, 0)]
RIGHT = [(0, 0, 0, 0), (0, 0, 0, 90), (0.4, -90, 0, -90), (0, 0, 0, 90), (0.39, -180, 0, -90), (0, 90, 0, 90), (0, -90, 0, 90)]
LEFT = [(0, 0, 0, 180), (0, 0, 0, 90), (-0.4, -90, 0, -90), (0, 0, 0, 90), (-0.39, 0, 0, -90), (0, 90, 0, -90), (0, -90, 0, -90)]
HEAD = [(0, 0, 0, 0), (0, 0, 0, -90)]
"""(d m, θ deg, r m, α deg) of each joint, as the data set's table lists them."""

MOUNTS = {"right": ((0.023, 0.084, -0.259), (180.0, 28.9, 180.0)), "left": ((0.021, 0.084, 0.248), (0.0, 30.0, 0.0))}
"""Each shoulder's mount on torso frame 3: xyz (m) and URDF roll-pitch-yaw (deg), from the frames-only fit."""

TORSO_KG = (8.0, 8.0, 8.0, 20.0)
ARM_KG = (2.5, 2.5, 2.5, 2.5, 2.0, 1.5, 2.5)
HEAD_KG = (0.5, 2.0)
HAND_COM = (0.0, 0.0, 0.1)
"""ESTIMATES: body masses (kg) of the torso's four links, each arm's seven and the head's two; the hand's centre of mass (m)."""

LIMIT = 3.2
"""Joint limits written (rad): wider than every commanded angle of the data set (at most 3.47 on torso joint 1)."""


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _origin(d: float, theta: float, r: float, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Translation and rotation of Rx(α) Tx(r) Rz(θ) Tz(d), angles in deg."""
    rx = _rx(math.radians(alpha))
    return np.array([r, 0.0, 0.0]) + rx @ np.array([0.0, 0.0, d]), rx @ _rz(math.radians(theta))


def _rpy(rotation: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw (R = Rz(y) Ry(p) Rx(r)) of a rotation; at pitch ±90° the roll is 0."""
    pitch = math.asin(-max(-1.0, min(1.0, rotation[2, 0])))
    if abs(abs(rotation[2, 0]) - 1.0) < 1e-12:
        return 0.0, pitch, math.atan2(-rotation[0, 1], rotation[1, 1])
    return math.atan2(rotation[2, 1], rotation[2, 2]), pitch, math.atan2(rotation[1, 0], rotation[0, 0])


def _number(x: float) -> str:
    text = f"{x:.15g}"
    return "0" if text == "-0" else text


def _link(name: str, mass: float = 0.0, com=(0.0, 0.0, 0.0)) -> str:
    if mass == 0.0:
        return f'  <link name="{name}"/>'
    xyz = " ".join(_number(c) for c in com)
    return (
        f'  <link name="{name}">\n    <inertial>\n      <origin xyz="{xyz}"/>\n      <mass value="{_number(mass)}"/>\n'
        '      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/>\n    </inertial>\n  </link>'
    )


def _joint(name: str, parent: str, child: str, translation, rotation, revolute: bool = True) -> str:
    xyz = " ".join(_number(c) for c in translation)
    rpy = " ".join(_number(a) for a in _rpy(rotation))
    text = f'  <joint name="{name}" type="{"revolute" if revolute else "fixed"}">\n'
    text += f'    <parent link="{parent}"/>\n    <child link="{child}"/>\n    <origin xyz="{xyz}" rpy="{rpy}"/>\n'
    if revolute:
        text += f'    <axis xyz="0 0 1"/>\n    <limit lower="{-LIMIT}" upper="{LIMIT + 0.3}" effort="200" velocity="2"/>\n'
    return text + "  </joint>"


def _chain(prefix: str, parent: str, rows, masses, last_com) -> list[str]:
    """The links and joints of one chain, each body's centre of mass halfway to the next joint."""
    origins = [_origin(*row) for row in rows]
    parts = []
    for i, (translation, rotation) in enumerate(origins):
        child = f"{prefix}{i + 1}"
        com = origins[i + 1][0] / 2 if i + 1 < len(origins) else np.array(last_com)
        parts += [_link(child, masses[i], com), _joint(f"{child}_joint", parent, child, translation, rotation)]
        parent = child
    return parts


def justin_urdf() -> str:
    """The URDF text."""
    parts = ['<?xml version="1.0"?>', "<!-- Written by examples/justin_urdf.py: sources and estimates are named there. -->",
             '<robot name="agile_justin_upper_body">', _link("base")]
    parts += _chain("torso", "base", TORSO, TORSO_KG, (0.0, 0.0, 0.0))
    for side, rows in (("right", RIGHT), ("left", LEFT)):
        mount = f"{side}_shoulder"
        xyz, (roll, pitch, yaw) = MOUNTS[side]
        turn = _rz(math.radians(yaw)) @ _ry(math.radians(pitch)) @ _rx(math.radians(roll))
        parts += [_link(mount), _joint(f"{mount}_mount", "torso4", mount, xyz, turn, revolute=False)]
        parts += _chain(side, mount, rows, ARM_KG, HAND_COM)
    parts += _chain("head", "torso4", HEAD, HEAD_KG, (0.0, 0.0, 0.1))
    parts.append("</robot>")
    return "\n".join(parts) + "\n"


if __name__ == "__main__":
    with open(sys.argv[1], "w", encoding="utf-8") as handle:
        handle.write(justin_urdf())
