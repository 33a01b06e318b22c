"""Simulated KR-270 worlds with kinematic errors, and their truth in the kinematic calibration's parameters.

A world is a calibration campaign (a random plan measured unloaded and loaded),
a held-out campaign (another random plan, read once) and the true value of every
parameter of :class:`~bayescal.kinematics.elastic.ArmPointModel`, from one of two
generators:

- ``"twin"``: the digital twin with a truth drawn around the cell's
  (:class:`~bayescal_studies.studies.elastostatic_coverage.TruthSpread`) and kinematic
  errors (:class:`~bayescal.twin.kinematic_errors.KinematicErrors`): each joint's
  error is, by construction, the calibration's own parameter;
- ``"independent"``: the independent generator with its own truth, tool, noise
  and DH errors (:mod:`bayescal.twin.independent.geometry`); each joint's true
  6-D correction is read off its placements, the log of ``nominal⁻¹ · true`` in
  the calibration's frame (:func:`placement_corrections`), exact for any
  parameterisation of the error.

In both the base frame is the tracker frame (the campaign files' convention), so
the base correction's truth is zero.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.inference.exact import scale_masses
from bayescal.kinematics.axes import joints_about_z
from bayescal.kinematics.cell import PointsCell
from bayescal_studies.studies.elastostatic_coverage import TruthSpread, random_plan
from bayescal.twin.kinematic_errors import COMPONENTS, KinematicErrors, with_kinematic_errors
from bayescal.twin.simulator import DigitalTwin

__all__ = ["GENERATORS", "KinematicWorld", "placement_corrections", "simulate_world"]

GENERATORS = ("twin", "independent")


@dataclass(frozen=True, eq=False)
class KinematicWorld:
    """A simulated calibration and held-out campaign, and the truth (SI) of each named calibration parameter."""

    campaign: Campaign
    held_out: Campaign
    truth: dict[str, float]


def placement_corrections(nominal: pin.Model, true: pin.Model) -> np.ndarray:
    """``(nq, 6)`` each joint's 6-D correction ``log(nominal⁻¹ · true)`` of its placement, in the calibration's frames.

    Both models are turned to their joints' z axes (:func:`~bayescal.kinematics.axes.joints_about_z`) first, so
    that the components are the kinematic calibration's ``tx, ty, tz, rx, ry, rz`` of each joint.
    """
    a, b = joints_about_z(nominal), joints_about_z(true)
    return np.array([np.array(pin.log6(a.jointPlacements[j].inverse() * b.jointPlacements[j]).vector) for j in range(1, a.njoints)])


def _truth(cell: Cell, points: PointsCell, corrections: np.ndarray, markers: dict[str, np.ndarray], spring,
           gravity_scale: float) -> dict[str, float]:
    """The calibration's parameters: joint corrections, the base (zero), markers (in ``cell``'s flange frame) turned into
    their joint's frame, the spring, the masses' scale."""
    tree = points.tree
    truth = {f"{tree.names[j]}.{c}": float(v) for j, row in enumerate(corrections, start=1) for c, v in zip(COMPONENTS, row)}
    truth |= {f"base.{c}": 0.0 for c in COMPONENTS}
    flange = tree.model.frames[tree.model.getFrameId(cell.robot.flange)].placement
    for marker in points.markers:
        truth |= {f"marker.{marker.name}.{a}": float(v) for a, v in zip("xyz", flange.act(markers[marker.name]))}
    if spring is not None:
        truth |= {"compensator.K_c": float(spring[0]), "compensator.K_c_s0": float(spring[0] * spring[1])}
    return truth | {"masses.gravity_scale": float(gravity_scale)}


def simulate_world(cell: Cell, points: PointsCell, rng: np.random.Generator, *, generator: str = "twin", scale: float = 1.0,
                   size: tuple[int, int, int] = (6, 10, 3), held_out: tuple[int, int] = (6, 5)) -> KinematicWorld:
    """One world of ``generator`` with kinematic errors ``scale`` times their realistic size.

    ``size`` is the calibration campaign's ``(angles, per_angle, repeats)``; ``held_out`` the held-out plan's
    ``(angles, per_angle)``, read once.
    """
    if generator not in GENERATORS:
        raise ValueError(f"generator must be one of {', '.join(GENERATORS)}, got {generator!r}")
    if generator == "independent":
        return _independent(cell, points, rng, scale, size, held_out)
    truth = TruthSpread().draw(cell, rng)
    world = dataclasses.replace(
        cell, robot=scale_masses(cell.robot, truth.masses), compliances=truth.compliances,
        compensator=None if truth.spring is None else cell.compensator.geometry.with_spring(*truth.spring),
    )
    errors = KinematicErrors.draw(cell.robot, rng, scale=scale)
    twin = DigitalTwin(with_kinematic_errors(world, errors))
    campaign = twin.simulate(random_plan(cell, *size[:2], rng), size[2], rng)
    test = twin.simulate(random_plan(cell, *held_out, rng), 1, rng)
    return KinematicWorld(campaign, test, _truth(cell, points, errors.deltas, cell.markers, truth.spring, truth.masses))


def _independent(cell: Cell, points: PointsCell, rng, scale, size, held_out) -> KinematicWorld:
    from bayescal.twin.independent.generator import IndependentGenerator
    from bayescal.twin.independent.plans import random_plan as independent_plan

    masses = cell.design.mass_range or (cell.load_mass, cell.load_mass)
    generator = IndependentGenerator(cell, rng, kinematic_errors=scale)
    world = generator.world()
    campaign, _ = generator.simulate(independent_plan(cell, rng, angles=size[0], per_angle=size[1], mass_kg=masses), size[2], world=world)
    test, _ = generator.simulate(independent_plan(cell, rng, angles=held_out[0], per_angle=held_out[1], mass_kg=masses), 1, world=world)
    true_robot = cell.robot if world.geometry is None else world.geometry.robot(cell.robot)
    spring = None if world.linkage is None else (world.linkage.K_c, world.linkage.s0)
    corrections = placement_corrections(cell.robot.model, true_robot.model)
    return KinematicWorld(campaign, test, _truth(cell, points, corrections, world.markers, spring, world.mass_scale))
