"""Mechanical effects beyond rigid links and linear joint springs, each a small physical model.

* :class:`KneeJoints`: a joint spring softer below a knee torque (a piecewise-linear torsion curve);
* :class:`GearPlay`: lost motion in the gears, held by friction until the torque pushes it
  across (a smoothed play operator), so that it depends on the order of the loads;
* :class:`LinkBeams`: the long links as tubular cantilevers under their own
  distributed weight and the loads beyond them, each moving its far end by a 6-D twist;
* :class:`ToolMount`: the tool on a compliant adaptor at the flange, with its own weight;
* :class:`RandomField`: a smooth random function of the joint angles and the marker,
  added to the load's deflection (a stand-in for whatever no catalogue names).

All are first order: the structure's deflections move the markers but do not feed
back into the joint torques.  SI units throughout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.robot.kinematics import Robot

__all__ = ["KneeJoints", "GearPlay", "ApproachPlay", "BeamSection", "LinkBeams", "ToolMount", "RandomField", "tube"]

LONG_LINK = 0.5
"""Shortest joint-to-joint distance (m) treated as a bending beam: the KR-270's upper arm
(1.25 m) and forearm (1.10 m) are, its 0.35 m column offset and 0.23 m wrist are not."""


@dataclass(frozen=True)
class KneeJoints:
    """Linear joint springs whose compliance is ``(1 + softening)·k`` below ``knee`` torque and ``k`` above.

    ``θ = k·τ + softening·k·clip(τ, -knee, knee)``: the two-slope torsion curve
    of a preloaded gear train, whose first slope is the softer one.
    """

    compliances: np.ndarray
    softening: float
    knee: np.ndarray

    def __call__(self, torque: np.ndarray) -> np.ndarray:
        """(nq,) deflections (rad) under (nq,) torques (N·m)."""
        return self.compliances * (torque + self.softening * np.clip(torque, -self.knee, self.knee))


@dataclass(frozen=True)
class GearPlay:
    """Lost motion of each joint's gears, a position between ``-play/2`` and ``+play/2`` (rad) with memory.

    Friction holds the gear in the play until the torque pushes it across: the
    position only moves when the torque leaves the band ``±hold``, toward the side it
    pushes, at most to ``play·tanh((|τ| - hold)/soft)`` from the far side: the play
    operator of hysteresis models, smoothed over ``soft``.  A joint whose torque keeps its sign beyond
    ``hold`` stays taken up; one whose torque crosses zero moves by up to ``play``.
    """

    play: np.ndarray
    hold: np.ndarray
    soft: np.ndarray

    def update(self, position: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """(nq,) play position (rad) under the joint torques ``torque`` (nq,) N·m, starting from ``position``."""
        half = self.play / 2.0
        upper = half - self.play * np.tanh(np.maximum(-(torque + self.hold), 0.0) / self.soft)
        lower = -half + self.play * np.tanh(np.maximum(torque - self.hold, 0.0) / self.soft)
        return np.clip(position, lower, upper)


@dataclass(frozen=True)
class ApproachPlay:
    """Lost motion whose side is the one each joint's servo last drove it to, a position in ``±play/2`` (rad).

    A servo drives the motor, and the motor drives the link through the gears'
    play: the driving flank leads, so a joint driven up (its angle increasing)
    stops with the link lagging on the lower side, ``-play/2``, and one driven down
    on the upper side, ``+play/2``.  A joint not moved keeps the side it had.  At
    rest the link stays on that flank until the torque on it (N·m, the sign that
    increases the angle) exceeds the gear train's friction ``hold`` the other way;
    it then crosses the play at once to the far flank and stays there until the
    torque exceeds ``hold`` back.  The side thus depends on the order of the
    configurations and the joints' direction of travel, not on the torque alone.

    Attributes
    ----------
    play : numpy.ndarray
        (nq,) total lost motion of each joint, rad.
    hold : numpy.ndarray
        (nq,) friction torque holding each link on its flank, N·m.
    home : numpy.ndarray
        (nq,) the joint angles (rad) the robot leaves for the first configuration;
        at home every joint was last driven up.
    """

    play: np.ndarray
    hold: np.ndarray
    home: np.ndarray

    def start(self) -> np.ndarray:
        """(nq,) play position (rad) at home: every joint last driven up, on its lower flank."""
        return -self.play / 2.0

    def arrive(self, position: np.ndarray, start: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """(nq,) play position (rad) after the servo drives the joints from ``start`` to ``goal`` (nq,) rad.

        Each joint that moves ends on the flank behind its motion; one that does not keeps ``position``.
        """
        direction = np.sign(np.asarray(goal, dtype=float) - np.asarray(start, dtype=float))
        return np.where(direction == 0.0, position, -direction * self.play / 2.0)

    def update(self, position: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """(nq,) play position (rad) at rest under the joint torques ``torque`` (nq,) N·m, starting from ``position``."""
        half = self.play / 2.0
        return np.where(torque > self.hold, half, np.where(torque < -self.hold, -half, position))


@dataclass(frozen=True)
class BeamSection:
    """Cross-section and material of a link seen as a straight prismatic beam (SI)."""

    EA: float
    EI: float
    GJ: float


def tube(outer: float, wall: float, E: float, G: float) -> BeamSection:
    """A round tube of ``outer`` diameter and ``wall`` thickness (m) of a material with moduli ``E``, ``G`` (Pa)."""
    inner = outer - 2.0 * wall
    area = math.pi * (outer**2 - inner**2) / 4.0
    second = math.pi * (outer**4 - inner**4) / 64.0
    return BeamSection(E * area, E * second, G * 2.0 * second)


def _beam_frame(axis: np.ndarray, joint_axis: np.ndarray) -> np.ndarray:
    """(3, 3) columns x along the beam, y along the joint axis made normal to it, z completing."""
    x = axis / np.linalg.norm(axis)
    y = joint_axis - (joint_axis @ x) * x
    if np.linalg.norm(y) < 1e-9:
        y = np.cross(x, [0.0, 0.0, 1.0]) if abs(x[2]) < 0.9 else np.cross(x, [1.0, 0.0, 0.0])
    y = y / np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def cantilever_twist(length: float, section: BeamSection, force, moment, weight_per_length) -> np.ndarray:
    """(6,) ``[δ; φ]`` of a cantilever's free end in its own axes (x along the beam), Euler-Bernoulli.

    ``force`` and ``moment`` (3,) act at the free end (N, N·m), ``weight_per_length``
    (3,) is a uniform load along it (N/m), all in the beam's axes.  Bending is the
    same about y and z (a round section).
    """
    ell, EI = length, section.EI
    F, M, w = (np.asarray(v, dtype=float) for v in (force, moment, weight_per_length))
    delta = np.array(
        [
            F[0] * ell / section.EA + w[0] * ell**2 / (2.0 * section.EA),
            F[1] * ell**3 / (3 * EI) + M[2] * ell**2 / (2 * EI) + w[1] * ell**4 / (8 * EI),
            F[2] * ell**3 / (3 * EI) - M[1] * ell**2 / (2 * EI) + w[2] * ell**4 / (8 * EI),
        ]
    )
    phi = np.array(
        [
            M[0] * ell / section.GJ,
            -F[2] * ell**2 / (2 * EI) + M[1] * ell / EI - w[2] * ell**3 / (6 * EI),
            F[1] * ell**2 / (2 * EI) + M[2] * ell / EI + w[1] * ell**3 / (6 * EI),
        ]
    )
    return np.concatenate([delta, phi])


@dataclass(frozen=True, eq=False)
class LinkBeams:
    """The long links of an arm as cantilevers from one joint's origin to the next.

    Parameters
    ----------
    sections
        One section per long link (joint-to-joint distance ≥ :data:`LONG_LINK`), in
        joint order; when there are more long links than sections the last is reused.
    scale
        Factor on every compliance (the effect's magnitude).
    gravity
        m/s², for the links' weights.
    """

    sections: tuple[BeamSection, ...]
    scale: float
    gravity: float

    def displacements(
        self, robot: Robot, q_link: np.ndarray, force: np.ndarray, point: np.ndarray, points: np.ndarray
    ) -> np.ndarray:
        """(k, 3) displacements (m) of flange-frame ``points`` from the bending of the long links.

        ``force`` (3,) N in base axes acts at the flange-frame ``point`` (the load);
        the links beyond each beam load its end with their weight, the beam's own
        link loads it uniformly.
        """
        model, data = robot.model, robot.model.createData()
        pin.forwardKinematics(model, data, q_link)
        pin.centerOfMass(model, data, q_link, True)
        origins = [data.oMi[j].translation.copy() for j in range(1, model.njoints)]
        load_at = robot.point_position(q_link, point)
        targets = robot.point_position(q_link, points)
        moved = np.zeros_like(targets)
        down = np.array([0.0, 0.0, -self.gravity])
        axes = robot.flange_jacobian(q_link)[3:]
        long_links = [j for j in range(len(origins) - 1) if np.linalg.norm(origins[j + 1] - origins[j]) >= LONG_LINK]
        for number, j in enumerate(long_links):
            root, tip = origins[j], origins[j + 1]
            frame = _beam_frame(tip - root, axes[:, j])
            beyond = data.mass[j + 2] * down if j + 2 < model.njoints else np.zeros(3)
            lever = data.com[j + 2] - tip if j + 2 < model.njoints else np.zeros(3)
            tip_force = beyond + force
            tip_moment = np.cross(lever, beyond) + np.cross(load_at - tip, force)
            own = model.inertias[j + 1].mass * down / np.linalg.norm(tip - root)
            section = self.sections[min(number, len(self.sections) - 1)]
            length = np.linalg.norm(tip - root)
            local = cantilever_twist(length, section, frame.T @ tip_force, frame.T @ tip_moment, frame.T @ own)
            delta, phi = frame @ local[:3], frame @ local[3:]
            moved += self.scale * (delta + np.cross(phi, targets - tip))
        return moved


@dataclass(frozen=True)
class ToolMount:
    """A tool of ``mass`` kg (centre ``centre`` in the flange frame, m) on a compliant adaptor at the flange.

    The adaptor turns by ``bending`` (about the flange's y and z) and ``torsion``
    (about its x) rad/(N·m) and shifts by ``shear`` m/N under the wrench it carries
    (the tool's weight plus the load), all in the flange's axes.
    """

    mass: float
    centre: np.ndarray
    bending: float
    torsion: float
    shear: float

    def displacements(
        self, rotation: np.ndarray, force: np.ndarray, point: np.ndarray, points: np.ndarray, gravity: float
    ) -> np.ndarray:
        """(k, 3) base-frame displacements (m) of flange-frame ``points`` with the flange turned by ``rotation``.

        ``force`` (3,) N in base axes acts at the flange-frame ``point``.
        """
        weight = np.array([0.0, 0.0, -self.mass * gravity])
        local_force = rotation.T @ (force + weight)
        local_moment = np.cross(point, rotation.T @ force) + np.cross(self.centre, rotation.T @ weight)
        turn = np.array([self.torsion, self.bending, self.bending]) * local_moment
        shift = self.shear * local_force
        return (shift + np.cross(turn, np.asarray(points, dtype=float))) @ rotation.T


@dataclass(frozen=True)
class RandomField:
    """A smooth random vector field over (joint angles, marker position), by random Fourier features.

    ``value(z) = Σ_i a_i cos(ω_i·z + b_i)`` with ``ω_i ~ N(0, I/ℓ²)`` and
    ``a_i ~ N(0, (2σ²/n) I)``: a draw from a Gaussian process of squared-exponential
    covariance, length scale ℓ (rad for the angles, the marker coordinates divided by
    ``marker_scale``) and standard deviation σ (m) per coordinate.
    """

    omega: np.ndarray
    phase: np.ndarray
    amplitude: np.ndarray
    marker_scale: float

    @classmethod
    def draw(
        cls, rng: np.random.Generator, n_inputs: int, *, sigma: float, length: float, marker_scale: float, features: int = 200
    ) -> RandomField:
        """A field over ``n_inputs`` joint angles plus 3 marker coordinates."""
        omega = rng.normal(scale=1.0 / length, size=(features, n_inputs + 3))
        phase = rng.uniform(0.0, 2.0 * math.pi, size=features)
        amplitude = rng.normal(scale=sigma * math.sqrt(2.0 / features), size=(features, 3))
        return cls(omega, phase, amplitude, marker_scale)

    def value(self, q: np.ndarray, points: np.ndarray) -> np.ndarray:
        """(k, 3) field values (m) at joint angles ``q`` (rad) for flange-frame ``points`` (k, 3)."""
        points = np.atleast_2d(points)
        inputs = np.hstack([np.broadcast_to(q, (len(points), len(q))), points / self.marker_scale])
        return np.cos(inputs @ self.omega.T + self.phase) @ self.amplitude
