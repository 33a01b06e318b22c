"""The effects the independent generator can plant, and the world they change.

An effect is a named change of the simulated world (:class:`World`): of the
arm's mechanics, of the tool, of the load, or of the tracker's readings.  Effects
are written in the package's one idiom (:class:`bayescal.twin.planted.Planted`):
a class per effect with its one-line ``summary``, its default size (``default``
in ``unit``, documented with its source or flagged as an estimate in
``docs/independent.md``) and the cause family a model criticism should name for
it (``cause``; ``None``: no family covers it, the right answer is
"unexplained"); an instance is the effect at one size, and the generator's
``magnitude`` is a multiple of the default.  The forms are this generator's own
and deliberately not those of the package's digital twin
(``bayescal.twin.effects``): the idiom is shared, the physics is not.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize_scalar

from bayescal.cell.config import Cell
from bayescal.twin.independent.geometry import GeometryErrors
from bayescal.twin.independent.noise import FrameDrift, LineOfSightJumps, ScaleError
from bayescal.twin.independent.solver import SpringLinkage
from bayescal.twin.independent.structure import ApproachPlay, GearPlay, KneeJoints, LinkBeams, RandomField, ToolMount, tube
from bayescal.twin.planted import Planted

__all__ = ["World", "PlantedEffect", "EFFECTS", "CAUSES"]

CAUSES = (
    "compensator",
    "link_compliance",
    "tool_compliance",
    "backlash",
    "nonlinear_stiffness",
    "outliers",
    "drift",
    "tracker_scale",
)
"""The cause families a model criticism may name; an effect outside all of them expects ``unexplained``."""


@dataclass(frozen=True, eq=False)
class World:
    """Everything true about a simulated campaign, SI: the arm, the tool, the load and the tracker.

    Attributes
    ----------
    compliances : numpy.ndarray
        (nq,) joint spring compliances, rad/(N·m) (the compensated joint's without its spring).
    linkage : SpringLinkage or None
        The gravity compensator as it truly is.
    mass_scale : float
        Factor on the URDF's link masses.
    load_point : numpy.ndarray
        (3,) where the load hangs, flange frame, m (written into the campaign).
    markers : dict of str to numpy.ndarray
        Marker positions, flange frame, m.
    knee, play, approach, beams, tool, field, jumps, drift, scale
        The planted effects' models, ``None`` when absent.
    geometry : GeometryErrors or None
        The joints' DH errors (:mod:`bayescal.twin.independent.geometry`); ``None``: the URDF's geometry.
    load_jitter : float
        Standard deviation (m, per axis) of the load point's shift each time the load is hung.
    field_force : float
        Force (N) at which the random field has its nominal size; it scales with the load.
    """

    compliances: np.ndarray
    linkage: SpringLinkage | None
    mass_scale: float
    load_point: np.ndarray
    markers: dict[str, np.ndarray]
    knee: KneeJoints | None = None
    play: GearPlay | None = None
    approach: ApproachPlay | None = None
    beams: LinkBeams | None = None
    tool: ToolMount | None = None
    field: RandomField | None = None
    jumps: LineOfSightJumps | None = None
    drift: FrameDrift | None = None
    scale: ScaleError | None = None
    geometry: GeometryErrors | None = None
    load_jitter: float = 0.0
    field_force: float = 1.0

    def joint_law(self):
        """The joints' deflection law, (nq,) N·m → (nq,) rad."""
        if self.knee is not None:
            return self.knee
        compliances = self.compliances
        return lambda torque: compliances * torque


@dataclass(frozen=True)
class PlantedEffect(Planted, ABC):
    """An effect of this generator at ``magnitude`` in its ``unit`` (the generator's multiple times ``default``).

    Besides the idiom's ``name``, ``unit``, ``default`` and ``summary``, its class gives ``cause``: the family of
    :data:`CAUSES` it belongs to, or None (expect ``unexplained``).
    """

    cause = None

    @abstractmethod
    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        """``world`` with the effect planted (its random parts drawn from ``rng``)."""


def _rated_torque(cell: Cell) -> np.ndarray:
    effort = np.array(cell.robot.model.effortLimit, dtype=float)
    if not np.all(np.isfinite(effort) & (effort > 0)):
        raise ValueError("this effect needs the URDF's effort limits (rated torques) on every joint")
    return effort


@dataclass(frozen=True)
class StiffSpringEffect(PlantedEffect):
    """A stiffer, progressive spring (the rate rises 15 % over a 200 mm stretch at the default size), its free
    length chosen as a maker would: the one whose moment is closest, in least squares over the joint's range,
    to the moment of the spring it replaces."""

    name, cause, default, unit = "stiff_spring", "compensator", 3.0, "factor on K_c"
    summary = "the compensator's spring stiffer (rate × the size), progressive, with a longer free length"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        if world.linkage is None:
            raise ValueError("the cell has no compensator whose spring could be changed")
        size, old = self.magnitude, world.linkage
        step = (size - 1.0) / (self.default - 1.0)
        joint = old.joint
        angles = np.linspace(cell.robot.lower[joint], cell.robot.upper[joint], 60)
        target = np.array([old.moment(angle) for angle in angles])

        def misfit(s0: float) -> float:
            new = replace(old, K_c=old.K_c * size, s0=s0, progression=0.15 * step)
            return float(np.sum((np.array([new.moment(angle) for angle in angles]) - target) ** 2))

        lengths = np.array([old.length(angle) for angle in angles])
        s0 = minimize_scalar(misfit, bounds=(0.0, float(lengths.max())), method="bounded").x if size > 0 else old.s0
        return replace(world, linkage=replace(old, K_c=old.K_c * size, s0=float(s0), progression=0.15 * step))


CAST_IRON = (169e9, 65e9)
"""Young's and shear moduli (Pa) of nodular cast iron EN-GJS-400 (EN 1563 typical values)."""
ARM_TUBES = ((0.34, 0.016), (0.24, 0.012))
"""Outer diameter and wall (m) of the upper arm and of the forearm as round tubes: ESTIMATES
sized from the KR-270's outline (upper arm about 350 mm deep, forearm about 250 mm)."""


@dataclass(frozen=True)
class LinkBeamsEffect(PlantedEffect):
    name, cause, default, unit = "link_beams", "link_compliance", 1.0, "factor on the tubes' compliance"
    summary = "upper arm and forearm bend and twist as cast-iron tubes under their own weight and the load beyond"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        sections = tuple(tube(outer, wall, *CAST_IRON) for outer, wall in ARM_TUBES)
        return replace(world, beams=LinkBeams(sections, self.magnitude, cell.gravity))


TOOL_MASS = 30.0
"""The tool's own mass, kg: ESTIMATE for a welded steel plate carrying markers and a lifting eye."""


@dataclass(frozen=True)
class ToolMountEffect(PlantedEffect):
    name, cause, default, unit = "tool_mount", "tool_compliance", 0.4, "μrad/(N·m) in bending"
    summary = "a 30 kg tool on an adaptor that turns under the bending moment (torsion 0.4 times it) and shears"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        size = self.magnitude
        # The tool's centre of mass: midway between the flange and the centroid of what it carries.
        carried = np.vstack([world.load_point, *world.markers.values()])
        centre = 0.5 * carried.mean(axis=0)
        mount = ToolMount(TOOL_MASS, centre, bending=size * 1e-6, torsion=0.4 * size * 1e-6, shear=0.5 * size * 1e-9)
        return replace(world, tool=mount)


@dataclass(frozen=True)
class GearPlayEffect(PlantedEffect):
    name, cause, default, unit = "gear_play", "backlash", 1.0, "arcmin of play per joint"
    summary = "lost motion of every joint's gears, held by friction until the torque exceeds 3 % of the rated torque the other way"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        rated = _rated_torque(cell)
        play = np.full(len(rated), self.magnitude * math.pi / (180.0 * 60.0))
        return replace(world, play=GearPlay(play, 0.03 * rated, 0.01 * rated))


APPROACH_PLAY = (0.5, 1.5)
"""Range of the factor (uniform) on each joint's lost motion: ESTIMATE, reducers of one arm differ in size and wear."""
APPROACH_HOLD = (0.01, 0.06)
"""Range (uniform) of each joint's friction hold as a fraction of its rated torque: ESTIMATE of a reducer's
breakaway torque at the output, a few per cent of rated."""


@dataclass(frozen=True)
class ApproachPlayEffect(PlantedEffect):
    name, cause, default, unit = "approach_play", "backlash", 1.0, "arcmin of play per joint"
    summary = (
        "lost motion of every joint on the flank its servo last drove it to (the direction of its last move, from a "
        "home pose), crossed when the torque exceeds a friction hold drawn per joint (1-6 % of rated); each joint's "
        "play the size times 0.5-1.5"
    )

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        rated = _rated_torque(cell)
        play = self.magnitude * math.pi / (180.0 * 60.0) * rng.uniform(*APPROACH_PLAY, len(rated))
        hold = rated * rng.uniform(*APPROACH_HOLD, len(rated))
        # Home: the middle of each joint's range (of its first turn), where a cell's programs start.
        home = 0.5 * (np.maximum(cell.robot.lower, -math.pi) + np.minimum(cell.robot.upper, math.pi))
        return replace(world, approach=ApproachPlay(play, hold, home))


@dataclass(frozen=True)
class KneeJointsEffect(PlantedEffect):
    name, cause, default, unit = "knee_joints", "nonlinear_stiffness", 0.5, "fraction of extra compliance"
    summary = "every joint spring softer by this fraction below 10 % of its rated torque"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        return replace(world, knee=KneeJoints(world.compliances, self.magnitude, 0.1 * _rated_torque(cell)))


@dataclass(frozen=True)
class LineOfSightJumpsEffect(PlantedEffect):
    name, cause, default, unit = "los_jumps", "outliers", 1.0, "mm"
    summary = "3 % of readings re-acquired off along the line of sight, by 0.5 to 1.5 times the size"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        return replace(world, jumps=LineOfSightJumps(0.03, 0.5 * self.magnitude * 1e-3, 1.5 * self.magnitude * 1e-3))


@dataclass(frozen=True)
class ThermalDriftEffect(PlantedEffect):
    name, cause, default, unit = "thermal_drift", "drift", 0.2, "mm/h"
    summary = (
        "the tracker's frame drifts in time: a steady translation, a 30 min cycle of a tenth of its hourly amount "
        "and a turn of 0.1 mrad/h per mm/h about the tracker"
    )

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        size, hour = self.magnitude, 3600.0
        drift = FrameDrift.draw(
            rng, rate=size * 1e-3 / hour, cycle=0.1 * size * 1e-3, period=0.5 * hour, spin_rate=0.1 * size * 1e-3 / hour
        )
        return replace(world, drift=drift)


@dataclass(frozen=True)
class TrackerScaleEffect(PlantedEffect):
    name, cause, default, unit = "tracker_scale", "tracker_scale", 20.0, "ppm"
    summary = "every distance from the tracker off by a relative error (refractive index)"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        return replace(world, scale=ScaleError(self.magnitude * 1e-6))


@dataclass(frozen=True)
class LoadRehangEffect(PlantedEffect):
    name, cause, default, unit = "load_rehang", None, 4.0, "mm standard deviation"
    summary = "the load hangs somewhere else on the tool each time it is hung (per axis)"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        return replace(world, load_jitter=self.magnitude * 1e-3)


FIELD_FORCE = 2600.0
"""Force (N) at which the random field has its nominal size: the weight of 265 kg."""


@dataclass(frozen=True)
class RandomFieldEffect(PlantedEffect):
    name, cause, default, unit = "random_field", None, 40.0, "μm per coordinate at 2600 N"
    summary = "a smooth random function of the joint angles and the marker added to the loaded deflection"

    def plant(self, world: World, cell: Cell, rng: np.random.Generator) -> World:
        field = RandomField.draw(rng, cell.robot.nq, sigma=self.magnitude * 1e-6, length=0.6, marker_scale=0.2)
        return replace(world, field=field, field_force=FIELD_FORCE)


EFFECTS: dict[str, type[PlantedEffect]] = {
    effect.name: effect
    for effect in (
        StiffSpringEffect, LinkBeamsEffect, ToolMountEffect, GearPlayEffect, ApproachPlayEffect, KneeJointsEffect,
        LineOfSightJumpsEffect, ThermalDriftEffect, TrackerScaleEffect, LoadRehangEffect, RandomFieldEffect,
    )
}
"""The effects by name, each a class: ``EFFECTS[name](EFFECTS[name].default * multiple)`` is one at a multiple of its default."""
