"""Physical effects the digital twin can plant in a simulated campaign.

Each effect is a small object with a documented default magnitude (the package's one idiom for
effects, :class:`bayescal.twin.planted.Planted`); it changes the twin at one of four places, the
others being left as they are:

* :meth:`Effect.compensator` - the cell's spring compensator;
* :meth:`Effect.joints` - the deflection law of the joint springs;
* :meth:`Effect.displacement` - an extra displacement of the tool's points
  under the external load (compliance outside the joints);
* :meth:`Effect.corrupt` - the tracker readings.

``parse_effect("NAME[=magnitude]")`` builds one from the command line.  The
magnitudes, their units and their sources are listed in :data:`EFFECTS` and in
``docs/twin.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from bayescal.robot.laws import CompensatorLaw
from bayescal.errors import InputError
from bayescal.robot.kinematics import Robot
from bayescal.robot.stiffness import JointLaw
from bayescal.twin.planted import Planted
from bayescal.units import DEG, MM, URAD_PER_NM

__all__ = [
    "Effect",
    "CompensatorScale",
    "LinkCompliance",
    "ToolCompliance",
    "Backlash",
    "NonlinearStiffness",
    "Outliers",
    "EFFECTS",
    "parse_effect",
]


@dataclass(frozen=True)
class Effect(Planted):
    """Base class: an effect of the twin that changes nothing.  ``magnitude`` is in the effect's :attr:`unit`."""

    def compensator(self, compensator: CompensatorLaw | None) -> CompensatorLaw | None:
        """The compensator the twin uses."""
        return compensator

    def joints(self, law: JointLaw, robot: Robot) -> JointLaw:
        """The joint deflection law the twin uses."""
        return law

    def displacement(self, robot: Robot, q, points, force, couple, load_point) -> np.ndarray:
        """(k, 3) extra displacement (m) of flange-frame ``points`` with the links at ``q``.

        ``force`` (N) acts at the flange-frame ``load_point``; ``couple`` (N·m) is the rest
        of the external wrench; both in base axes.
        """
        return np.zeros((len(points), 3))

    def corrupt(self, measured: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The tracker readings (k, 3), m, as the effect leaves them."""
        return measured


@dataclass(frozen=True)
class CompensatorScale(Effect):
    """The cell's compensator with its spring stiffness ``K_c`` multiplied by the magnitude.

    The compensator is on whenever the cell has one; ``compensator=0`` removes it and
    leaves a plain serial robot, other values mis-state the spring.  The free length
    is kept, so a stiffer spring no longer balances the arm: on Table III the arm
    sags before loading by up to 1.1°, 2.2° and 5.5° at 10, 20 and 50 times K_c.
    """

    name = "compensator"
    unit = "x K_c"
    default = 1.0
    summary = "the cell's spring compensator, K_c scaled by the magnitude (0: a plain serial robot)"

    def compensator(self, compensator: CompensatorLaw | None) -> CompensatorLaw | None:
        if compensator is None or self.magnitude == 0:
            return None
        # The law's first parameter sets its force's scale: the spring's K_c.
        name = compensator.PARAMETERS[0].name
        return replace(compensator, **{name: getattr(compensator, name) * self.magnitude})


def _beam_compliance(length: float, EI: float, GJ: float, EA: float) -> np.ndarray:
    """Tip compliance (6, 6) of a cantilever along its local x axis, twist ``[δp; δφ]`` from wrench ``[f; m]``.

    Euler-Bernoulli bending in both transverse planes, axial stretch and torsion.
    """
    c = np.zeros((6, 6))
    bend_f, bend_c, bend_m = length**3 / (3 * EI), length**2 / (2 * EI), length / EI
    c[0, 0] = length / EA
    c[3, 3] = length / GJ
    c[1, 1], c[1, 5], c[5, 1], c[5, 5] = bend_f, bend_c, bend_c, bend_m
    c[2, 2], c[2, 4], c[4, 2], c[4, 4] = bend_f, -bend_c, -bend_c, bend_m
    return c


def _rigid_motion(twist: np.ndarray, centre: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Displacements of ``points`` under the small rigid motion ``twist = [δp; δφ]`` about ``centre``."""
    return twist[:3] + np.cross(twist[3:], points - centre)


@dataclass(frozen=True)
class LinkCompliance(Effect):
    """Bending, stretch and torsion of the upper arm (joint 2 to 3) and the forearm (joint 4 to 5).

    Each is a cantilever from its joint to the next, loaded at its end by the external
    wrench.  Sections (ESTIMATES, KR-270-like cast-iron arm, E = 170 GPa, G = 65 GPa):
    upper arm a 350 x 300 mm box with 15 mm walls, EI = 4.5e7 N·m², GJ = 3.5e7 N·m²,
    EA = 3.3e9 N; forearm a 250 mm tube with 15 mm walls, EI = 1.3e7 N·m²,
    GJ = 1.0e7 N·m², EA = 1.9e9 N.  The magnitude multiplies these compliances.
    Only the external load is applied: the links' own weight bends them equally in
    both states and cancels in the deflections.
    """

    name = "link_compliance"
    unit = "x estimated beam compliance"
    default = 1.0
    summary = "bending of the upper arm and the forearm as cantilever beams"

    SECTIONS = ((1, 2, 4.5e7, 3.5e7, 3.3e9), (3, 4, 1.3e7, 1.0e7, 1.9e9))
    """(root joint, tip joint, EI, GJ, EA), joints 0-based."""

    def displacement(self, robot, q, points, force, couple, load_point) -> np.ndarray:
        if self.magnitude == 0:
            return np.zeros((len(points), 3))
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, np.asarray(q, dtype=float))
        base_points, load = robot.point_position(q, points), robot.point_position(q, load_point)
        total = np.zeros((len(points), 3))
        for root, tip, EI, GJ, EA in self.SECTIONS:
            start = data.oMi[root + 1].translation
            end = data.oMi[tip + 1].translation
            axis = end - start
            length = float(np.linalg.norm(axis))
            # beam frame: x along the beam, the root joint's frame fixing the other two axes
            x = axis / length
            helper = data.oMi[root + 1].rotation[:, 2]
            if abs(helper @ x) > 0.9:
                helper = data.oMi[root + 1].rotation[:, 1]
            z = np.cross(x, helper)
            z /= np.linalg.norm(z)
            frame = np.column_stack([x, np.cross(z, x), z])
            wrench = np.concatenate([force, np.cross(load - end, force) + couple])
            local = _beam_compliance(length, EI, GJ, EA) @ np.concatenate([frame.T @ wrench[:3], frame.T @ wrench[3:]])
            twist = self.magnitude * np.concatenate([frame @ local[:3], frame @ local[3:]])
            total += _rigid_motion(twist, end, base_points)
        return total


@dataclass(frozen=True)
class ToolCompliance(Effect):
    """The end-effector tilts on a compliant mount at the flange under the load's bending moment.

    The magnitude is the mount's rotational compliance about the two axes
    perpendicular to the flange axis, μrad/(N·m); default 0.3 (ESTIMATE: a bolted
    adaptor plate about ten times stiffer than A5).  Twist about the flange axis is
    left out: it would only add to A6's compliance.
    """

    name = "tool_compliance"
    unit = "μrad/(N·m)"
    default = 0.3
    summary = "the tool tilts on a compliant mount at the flange"

    def displacement(self, robot, q, points, force, couple, load_point) -> np.ndarray:
        rotation, origin = robot.flange_pose(q)
        base_points = np.asarray(points) @ rotation.T + origin
        load = rotation @ np.asarray(load_point) + origin
        moment = rotation.T @ (np.cross(load - origin, force) + couple)
        moment[0] = 0.0
        tilt = rotation @ (self.magnitude * URAD_PER_NM * moment)
        return np.cross(tilt, base_points - origin)


class _DeadBand:
    def __init__(self, inner: JointLaw, width: float, smoothing: np.ndarray) -> None:
        self.inner, self.width, self.smoothing = inner, width, smoothing

    def deflection(self, torque):
        return self.inner.deflection(torque) + self.width * np.tanh(torque / self.smoothing)

    def slope(self, torque):
        return self.inner.slope(torque) + self.width / self.smoothing / np.cosh(torque / self.smoothing) ** 2


class _Hardening:
    def __init__(self, inner: JointLaw, beta: float, reference: np.ndarray) -> None:
        self.inner, self.beta, self.reference = inner, beta, reference

    def deflection(self, torque):
        return self.inner.deflection(torque) / (1.0 + self.beta * np.abs(torque) / self.reference)

    def slope(self, torque):
        factor = 1.0 + self.beta * np.abs(torque) / self.reference
        # exact for a linear inner law, which is what the twin's order of effects guarantees
        return self.inner.slope(torque) / factor**2


def _rated_torques(robot: Robot, effect: str) -> np.ndarray:
    rated = np.array(robot.model.effortLimit, dtype=float)
    if not np.all(np.isfinite(rated) & (rated > 0)):
        raise InputError(
            f"effect '{effect}' needs every joint's rated torque as the URDF's effort limit; got {rated.tolist()} N·m",
            source=robot.source,
        )
    return rated


@dataclass(frozen=True)
class Backlash(Effect):
    """A dead band in every joint: the link moves by ± the magnitude (deg) in the direction of the joint torque.

    Default 0.015 deg, about 1 arcmin of lost motion (ESTIMATE, the order of
    precision RV-type reducers are sold with).  The sign is smoothed over 1 % of the
    joint's rated torque (URDF effort limit) so the equilibrium stays differentiable.
    With the arm's weight preloading the joints, the dead band only shows where the
    load reverses a joint's torque.
    """

    name = "backlash"
    unit = "deg"
    default = 0.015

    summary = "a dead band in the joints, signed by the joint torque"

    def joints(self, law: JointLaw, robot: Robot) -> JointLaw:
        return _DeadBand(law, self.magnitude * DEG, 0.01 * _rated_torques(robot, self.name))


@dataclass(frozen=True)
class NonlinearStiffness(Effect):
    """Joint springs that stiffen with torque: ``θ_j = k_j τ_j / (1 + β |τ_j| / τ_rated,j)``.

    The magnitude is β, the relative stiffening at the rated torque (URDF effort
    limit); default 0.3 (ESTIMATE: gear-train torsional curves are typically
    tens of percent stiffer at rated torque than near zero).
    """

    name = "nonlinear_stiffness"
    unit = "relative stiffening at rated torque"
    default = 0.3
    summary = "joint stiffness that grows with the joint torque"

    def joints(self, law: JointLaw, robot: Robot) -> JointLaw:
        return _Hardening(law, self.magnitude, _rated_torques(robot, self.name))


@dataclass(frozen=True)
class Outliers(Effect):
    """Gross tracker errors: each reading is, with probability = magnitude, off by 0.5-2 mm in a random direction.

    Default 0.01 (1 % of the points; ESTIMATE of beam breaks and mis-seated reflectors).
    """

    name = "outliers"
    unit = "fraction of readings"
    default = 0.01
    summary = "a few gross tracker errors of 0.5-2 mm"

    SIZE = (0.5 * MM, 2.0 * MM)

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.magnitude > 1:
            raise ValueError(f"effect 'outliers' needs a fraction between 0 and 1, got {self.magnitude:g}")

    def corrupt(self, measured: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        hit = rng.random(len(measured)) < self.magnitude
        direction = rng.normal(size=measured.shape)
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        size = rng.uniform(*self.SIZE, size=len(measured))
        return measured + hit[:, np.newaxis] * size[:, np.newaxis] * direction


EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls for cls in (CompensatorScale, LinkCompliance, ToolCompliance, NonlinearStiffness, Backlash, Outliers)
}
"""The effects by name, in the order the twin applies them (the dead band wraps the hardening law)."""


def parse_effect(text: str, source: str | None = None) -> Effect:
    """Build an effect from ``NAME`` (default magnitude) or ``NAME=magnitude``.

    Raises
    ------
    InputError
        An unknown name or an invalid magnitude, naming ``source`` (where the text came from).
    """
    name, _, value = text.partition("=")
    name = name.strip()
    if name not in EFFECTS:
        raise InputError(f"unknown effect '{name}'; expected one of {', '.join(EFFECTS)}", source=source)
    cls = EFFECTS[name]
    if not value.strip():
        return cls(cls.default)
    try:
        magnitude = float(value)
    except ValueError:
        raise InputError(f"effect '{name}' needs a number in {cls.unit}, got '{value}'", source=source) from None
    try:
        return cls(magnitude)
    except ValueError as error:
        raise InputError(str(error), source=source) from None
