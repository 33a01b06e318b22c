"""The generator's own KR-270-class robot: a chain of rigid pieces, joints and elastic elements, with its masses.

The chain is a tuple of :class:`Item` from the base to the tool, each mapping the frame
before it to the frame after it:

* ``fixed``: a constant transform;
* ``joint``: a rotation about ``axis`` by the commanded angle plus its zero offset, its
  elastic twist (the joint's law of torque) and its play (lost motion);
* ``elastic``: a constant transform (a beam segment's length along x, or nothing for a
  hinge) followed by a small deformation ``[δ; φ] = C w``, with ``w`` the wrench carried
  through the item, taken about the frame after it and in its axes.

A point load (a link's weight, the tool's, the hanging mass, the compensator's spring)
is attached after an item: it is carried by every joint and elastic element up to and
including that item.  Only the joint origins and axes come from the robot's URDF (the
kinematic chain); every other number here is this generator's own, near the cell's
(``data/kr270.toml``) but deliberately not equal to it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from bayescal.twin.beams.beam import Section, timoshenko_compliance

__all__ = ["Item", "PointMass", "Compensator", "JointLaws", "Tool", "Robot", "urdf_chain", "rotation"]

URDF = Path(__file__).resolve().parents[3] / "data" / "robots" / "kr270.urdf"
"""The robot description whose joint origins and axes the generator's chain starts from."""


def rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def transform(R: np.ndarray | None = None, p=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(4, 4) homogeneous transform of rotation ``R`` (identity when None) and translation ``p`` (m)."""
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    T[:3, 3] = p
    return T


@dataclass(frozen=True)
class Item:
    """One piece of the chain (module documentation); unused fields are None or -1."""

    kind: str
    name: str
    offset: np.ndarray
    axis: np.ndarray | None = None
    joint: int = -1
    compliance: np.ndarray | None = None


@dataclass(frozen=True)
class PointMass:
    """A weight ``mass`` (kg) at ``point`` (m) in the frame after chain item ``item``."""

    name: str
    item: int
    point: np.ndarray
    mass: float


@dataclass(frozen=True)
class Compensator:
    """The spring between the column (``p0`` after item ``item0``) and the upper arm's lever (``p1`` after ``item1``), SI.

    It pulls the two points together with ``K e`` at distance ``s`` (``e = s − s0``, a linear coil
    spring) blended, by ``gas`` from 0 to 1, into a hydropneumatic spring's
    ``K e_ref (ℓ / (ℓ − (s − s_ref)))^n``: the same force at the reference length ``s_ref = s0 + e_ref``
    (the arm horizontal), a gas column of length ``gas_length`` ℓ compressed polytropically (``n``)
    as the rod is drawn out, so progressive, with rate ``n K e_ref/ℓ`` at ``s_ref``.
    """

    item0: int
    p0: np.ndarray
    item1: int
    p1: np.ndarray
    K: float
    s0: float
    e_ref: float
    gas: float = 0.0
    gas_length: float = 1.0
    polytropic: float = 1.3

    def force(self, s: float) -> float:
        """Tension (N) at length ``s`` (m)."""
        linear = self.K * (s - self.s0)
        if self.gas == 0.0:
            return linear
        column = self.gas_length - (s - self.s0 - self.e_ref)
        if column <= 0:
            raise ValueError(f"the compensator's gas column is used up at s = {s:.4f} m (gas length {self.gas_length:.4f} m)")
        return linear + self.gas * (self.K * self.e_ref * (self.gas_length / column) ** self.polytropic - linear)


@dataclass(frozen=True)
class JointLaws:
    """Each joint's twist under its torque τ, SI: ``k`` (rad/(N·m)), hardening, play band and friction.

    The elastic twist is ``k τ`` for ``hardening`` α = 0; otherwise the stiffness grows with the
    torque as ``(1 + α |τ|/τ_rated)/k``, so the twist is ``k τ_rated/α · sign(τ) ln(1 + α|τ|/τ_rated)``.
    ``play`` (rad) is each joint's lost-motion band and ``friction`` (N·m) the torque that
    moves the joint across it.
    """

    k: np.ndarray
    rated: np.ndarray
    hardening: float = 0.0
    play: np.ndarray = field(default_factory=lambda: np.zeros(6))
    friction: np.ndarray = field(default_factory=lambda: np.zeros(6))

    def twist(self, torque: np.ndarray) -> np.ndarray:
        """(6,) elastic twists (rad) under ``torque`` (6,) N·m."""
        if self.hardening == 0.0:
            return self.k * torque
        x = self.hardening * np.abs(torque) / self.rated
        return self.k * np.sign(torque) * self.rated / self.hardening * np.log1p(x)


@dataclass(frozen=True)
class Tool:
    """The calibration end-effector, in the flange frame (m): where the mass hangs and the reflectors sit."""

    item: int
    load_point: np.ndarray
    markers: dict[str, np.ndarray]


@dataclass(frozen=True)
class Robot:
    """The whole arm: its chain, weights, compensator, joint laws and tool; SI units.

    ``nominal`` is the chain of the URDF alone (its joint origins, no elasticity): the
    kinematics a user computes the wrench columns with.
    """

    items: tuple[Item, ...]
    masses: tuple[PointMass, ...]
    compensator: Compensator
    joints: JointLaws
    zero_offset: np.ndarray
    tool: Tool
    nominal: tuple[Item, ...]
    gravity: float = 9.80665

    def with_joints(self, **changes) -> Robot:
        """A copy with the joint laws' fields in ``changes`` replaced."""
        return replace(self, joints=replace(self.joints, **changes))

    def with_compensator(self, **changes) -> Robot:
        """A copy with the compensator's fields in ``changes`` replaced."""
        return replace(self, compensator=replace(self.compensator, **changes))

    def with_elastic(self, names: tuple[str, ...], factor: float) -> Robot:
        """A copy whose elastic items named in ``names`` are ``factor`` times as compliant."""
        items = tuple(
            replace(item, compliance=item.compliance * factor) if item.kind == "elastic" and item.name in names else item
            for item in self.items
        )
        return replace(self, items=items)


def urdf_chain(path: Path = URDF, tip: str = "flange") -> list[dict]:
    """The joints from the URDF's root to link ``tip``, in order: name, child link, type, origin (m), rpy (rad), axis.

    A fixed joint has ``axis`` None.  The URDF's inertias are not read: the generator has its own masses.
    """
    root = ET.parse(path).getroot()
    by_child = {joint.find("child").get("link"): joint for joint in root.findall("joint")}
    chain, link = [], tip
    while link in by_child:
        joint = by_child[link]
        origin = joint.find("origin")
        axis = joint.find("axis")
        chain.append(
            {
                "name": joint.get("name"),
                "child": link,
                "type": joint.get("type"),
                "xyz": np.array([float(v) for v in origin.get("xyz", "0 0 0").split()]),
                "rpy": np.array([float(v) for v in origin.get("rpy", "0 0 0").split()]),
                "axis": None if joint.get("type") == "fixed" else np.array([float(v) for v in axis.get("xyz").split()]),
            }
        )
        link = joint.find("parent").get("link")
    return chain[::-1]


def rpy_rotation(rpy: np.ndarray) -> np.ndarray:
    """(3, 3) rotation of URDF roll, pitch, yaw (rad): ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    roll, pitch, yaw = rpy
    return rotation(np.array([0.0, 0.0, 1.0]), yaw) @ rotation(np.array([0.0, 1.0, 0.0]), pitch) @ rotation(np.array([1.0, 0.0, 0.0]), roll)


def nominal_items(chain: list[dict]) -> tuple[Item, ...]:
    """The URDF's chain as rigid items: each joint's origin then its rotation."""
    items, index = [], 0
    for joint in chain:
        items.append(Item("fixed", joint["name"] + " origin", transform(rpy_rotation(joint["rpy"]), joint["xyz"])))
        if joint["axis"] is not None:
            items.append(Item("joint", joint["name"], np.eye(4), axis=joint["axis"] / np.linalg.norm(joint["axis"]), joint=index))
            index += 1
    return tuple(items)


def beam_items(name: str, length: float, stations: list[float], section: Section) -> list[Item]:
    """A beam of ``length`` (m) along x as elastic segments ending at each of ``stations`` (m from its root) and its tip."""
    ends = sorted(set(stations) | {length})
    items, start = [], 0.0
    for number, end in enumerate(ends, 1):
        segment = end - start
        items.append(Item("elastic", f"{name} {number}", transform(p=(segment, 0.0, 0.0)), compliance=timoshenko_compliance(segment, section)))
        start = end
    return items
