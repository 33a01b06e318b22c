"""The generator's KR-270-class arm: its own numbers, near the cell's but not equal to them.

Only the kinematic chain (joint origins and axes) is read from ``data/robots/kr270.urdf``;
the URDF's masses and the cell file's (``data/kr270.toml``) compliances, compensator and
tool are not read.  Every number below is an ESTIMATE of this generator's own, chosen
near what the cell believes so that the method meets a plausible robot it was not built
from: where a number departs from the cell's, by how much is stated beside it.
"""

from __future__ import annotations

import numpy as np

from bayescal.twin.beams.beam import box_section, tube_section
from bayescal.twin.beams.robot import (
    URDF,
    Compensator,
    Item,
    JointLaws,
    PointMass,
    Robot,
    Tool,
    beam_items,
    nominal_items,
    rpy_rotation,
    transform,
    urdf_chain,
)
from bayescal.units import DEG, MM, N_PER_MM, URAD_PER_NM

__all__ = ["kr270_class", "LENGTH_CHANGE_MM", "JOINT_COMPLIANCE_URAD_PER_NM"]

LENGTH_CHANGE_MM = {"A1": (0.0, 0.0, 0.25), "A2": (-0.35, 0.0, 0.0), "A3": (0.42, 0.0, 0.0), "A4": (0.0, 0.0, -0.18), "A5": (-0.30, 0.0, 0.0), "A6": (0.15, 0.0, 0.0)}
"""This arm's joint origins minus the URDF's (mm): a few tenths of a mm, as a robot off the line differs from its drawing."""
ZERO_OFFSET_DEG = np.array([0.004, -0.006, 0.005, -0.009, 0.008, -0.006])
"""Each joint's actual angle minus the commanded one at rest (deg): encoder zeros off by 10-30 arcsec."""
JOINT_COMPLIANCE_URAD_PER_NM = np.array([0.28, 0.27, 0.37, 2.9, 3.1, 2.3])
"""The gears' compliances (μrad/(N·m)), 3-11 % below the cell's [0.30, 0.302, 0.406, 3.002, 3.303, 2.365]:
the links' bending, which the cell lumps into its joints, is apart here."""
RATED_TORQUE_NM = np.array([24000.0, 24000.0, 14000.0, 2600.0, 2600.0, 1300.0])
"""Rated torque of each gear (N·m), the scale of the torque-dependent effects; the URDF's efforts lowered by 4-13 %."""

STEEL = (200e9, 78e9)
"""Cast steel's Young's and shear moduli (Pa): the upper arm."""
CAST_IRON = (169e9, 66e9)
"""Spheroidal-graphite cast iron's (EN-GJS-400) moduli (Pa): the forearm."""
UPPER_ARM = {"root": 0.20, "tip": 0.16, "section": box_section(0.36, 0.42, 0.020, *STEEL)}
"""The upper arm between its hubs (m from A2 and before A3): a 360 mm wide, 420 mm deep box with 20 mm walls."""
FOREARM = {"root": 0.22, "tip": 0.12, "section": tube_section(0.28, 0.012, *CAST_IRON)}
"""The forearm tube between its hubs (m from A4 and before A5): 280 mm across, 12 mm wall."""

MASSES = {
    "link1": (430.0, (0.14, 0.0, -0.21)),
    "link2": (268.0, (0.53, 0.0, 0.02)),
    "link3": (188.0, (-0.06, 0.0, -0.045)),
    "link4": (84.0, (0.57, 0.0, 0.0)),
    "link5": (33.0, (0.09, 0.0, 0.0)),
    "link6": (6.0, (0.016, 0.0, 0.0)),
    "tool": (38.0, (0.17, 0.0, 0.09)),
}
"""Each body's mass (kg) and centre of mass (m, in its link's frame; the tool's in the flange frame): within
10 % of the URDF's estimates (430 for 420 kg, 268 for 280 ...; the 6 kg flange 20 %); the tool's 38 kg is the generator's own."""

COMPENSATOR = {"L": 185.2 * MM, "a_x": 687.2 * MM, "a_y": 119.6 * MM, "phi": 100.3 * DEG, "K": 150.0 * N_PER_MM, "s0": 452.0 * MM, "side": 0.21}
"""The spring compensator (cell: L 184.72, a_x 685.93, a_y 120.30 mm, φ 99.96°, K_c 144 N/mm, s0 458 mm): the lever
P1 at L from A2's axis at angle φ (from the upper arm's x toward its z) when q2 = 0, the column's pivot P0 at
(−a_x, −a_y) from A2's axis in the x-z plane, both ``side`` (m) beside the arm along A2's axis."""

HINGE = {"offset": 0.045, "axis": (1.0, 0.20, -0.12), "torsion": 0.25 * URAD_PER_NM, "bending": 0.11 * URAD_PER_NM}
"""The tool mount: a hinge ``offset`` (m) out along the flange axis, turning about its own ``axis`` (flange frame,
13° off the flange axis: an adapter plate's locating pin off centre) with compliances (rad/(N·m)) in torsion about
it and in bending across it, those of a bolted tool changer of this size (ESTIMATES)."""

TOOL = {
    "load_point": (250.6, -0.4, 299.3),
    "markers": {"M1": (200.05, 0.04, 115.52), "M2": (199.96, -100.06, -57.69), "M3": (200.03, 100.02, -57.78)},
}
"""The end-effector (mm, flange frame): the load point 1.0 mm and the reflectors within 0.1 mm of the cell's
(250, 0, 300); M1 (200, 0, 115.47), M2 (200, −100, −57.735), M3 (200, 100, −57.735)."""


def kr270_class() -> Robot:
    """The generator's KR-270-class arm (numbers in the module's constants)."""
    chain = urdf_chain(URDF)
    items: list[Item] = []
    body: dict[str, int] = {}
    compensator_items = {}
    joints = 0
    for joint in chain:
        xyz = joint["xyz"] + np.asarray(LENGTH_CHANGE_MM.get(joint["name"], (0.0, 0.0, 0.0))) * MM
        R = rpy_rotation(joint["rpy"])
        if joint["name"] == "A2":
            # The column's pivot rides on link 1, the body before A2's origin.
            compensator_items["p0"] = (len(items) - 1, xyz)
        if joint["name"] in ("A3", "A5"):
            spec, link, beam = (UPPER_ARM, "link2", "upper arm") if joint["name"] == "A3" else (FOREARM, "link4", "forearm")
            items.extend(_beam_link(spec, beam, xyz, R, MASSES[link][1][0]))
            # The link's weight rides on the node at its centre of mass, the end of the beam's first segment.
            body[link] = len(items) - 3
        else:
            items.append(Item("fixed", joint["name"] + " origin", transform(R, xyz)))
        if joint["axis"] is not None:
            items.append(Item("joint", joint["name"], np.eye(4), axis=joint["axis"] / np.linalg.norm(joint["axis"]), joint=joints))
            joints += 1
            body.setdefault(joint["child"], len(items) - 1)
            if joint["name"] == "A2":
                compensator_items["p1"] = len(items) - 1
    items.extend(_hinge())
    tool_item = len(items) - 1
    masses = tuple(PointMass(name, body.get(name, tool_item), _mass_point(name, items, body), mass) for name, (mass, _) in MASSES.items())
    return Robot(
        items=tuple(items),
        masses=masses,
        compensator=_compensator(compensator_items),
        joints=JointLaws(k=JOINT_COMPLIANCE_URAD_PER_NM * URAD_PER_NM, rated=RATED_TORQUE_NM.copy()),
        zero_offset=ZERO_OFFSET_DEG * DEG,
        tool=Tool(
            item=tool_item,
            load_point=np.asarray(TOOL["load_point"]) * MM,
            markers={name: np.asarray(p) * MM for name, p in TOOL["markers"].items()},
        ),
        nominal=nominal_items(chain),
    )


def _beam_link(spec: dict, name: str, xyz: np.ndarray, R: np.ndarray, com_x: float) -> list[Item]:
    """The items from a link's joint to the next joint's origin ``xyz`` (along x): hub, beam to the centre of mass and on, hub."""
    if abs(xyz[1]) > 1e-12 or abs(xyz[2]) > 1e-12 or not np.allclose(R, np.eye(3)):
        raise ValueError(f"the {name} must run along its link's x axis to be a beam; the URDF gives {xyz}")
    length = xyz[0] - spec["root"] - spec["tip"]
    hub = Item("fixed", f"{name} root hub", transform(p=(spec["root"], 0.0, 0.0)))
    rest = Item("fixed", f"{name} tip hub", transform(p=(spec["tip"], 0.0, 0.0)))
    return [hub, *beam_items(name, length, [com_x - spec["root"]], spec["section"]), rest]


def _hinge() -> list[Item]:
    """The tool mount: out to the hinge, the hinge's rotation-only compliance about its own axis, back to the flange's origin."""
    axis = np.asarray(HINGE["axis"]) / np.linalg.norm(HINGE["axis"])
    C = np.zeros((6, 6))
    C[3:, 3:] = HINGE["torsion"] * np.outer(axis, axis) + HINGE["bending"] * (np.eye(3) - np.outer(axis, axis))
    out = Item("fixed", "tool mount", transform(p=(HINGE["offset"], 0.0, 0.0)))
    back = Item("fixed", "tool", transform(p=(-HINGE["offset"], 0.0, 0.0)))
    return [out, Item("elastic", "tool mount hinge", np.eye(4), compliance=C), back]


def _mass_point(name: str, items: list[Item], body: dict[str, int]) -> np.ndarray:
    """A body's centre of mass in the frame it is attached to: a beam's sits on the node at its x, so only y, z remain."""
    point = np.asarray(MASSES[name][1], dtype=float)
    if name in body and items[body[name]].kind == "elastic":
        return np.array([0.0, point[1], point[2]])
    return point


def _compensator(where: dict) -> Compensator:
    """The spring between the column and the upper arm (numbers in :data:`COMPENSATOR`), its reference extension at q2 = 0."""
    c = COMPENSATOR
    item0, a2 = where["p0"]
    p0 = a2 + np.array([-c["a_x"], c["side"], -c["a_y"]])
    p1 = np.array([c["L"] * np.cos(c["phi"]), c["side"], c["L"] * np.sin(c["phi"])])
    s_ref = float(np.linalg.norm(p1 - (p0 - a2)))
    return Compensator(item0=item0, p0=p0, item1=where["p1"], p1=p1, K=c["K"], s0=c["s0"], e_ref=s_ref - c["s0"])
