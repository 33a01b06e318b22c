"""The independent generator: campaigns with known truth, unlike the cell's configuration.

``IndependentGenerator(cell, rng).simulate(plan, repeats, effect, magnitude)``
returns a :class:`~bayescal.cell.campaign.Campaign` in the format
``bayescal calibrate`` reads and a :class:`Truth`.  By default the truth is drawn
around the cell's values (:data:`SPREADS`) and the tool is the generator's own
(load point and markers moved from the cell's), so that no campaign is the
configuration's twin; ``truth="config"`` keeps the cell's values exactly.

Each repeat of a configuration is read unloaded, then loaded, in the order of the
plan; the readings carry times from :data:`TIMELINE`, written in the campaign's
``t0_s, t1_s`` columns as a tracker stamps them.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.nests import Nests
from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.errors import InputError
from bayescal.twin.independent.effects import EFFECTS, World
from bayescal.twin.independent.geometry import GeometryErrors
from bayescal.twin.independent.noise import TrackerReadout
from bayescal.twin.independent.solver import Load, SolverError, SpringLinkage, Statics, scaled_robot
from bayescal.units import MM, N_PER_MM, URAD_PER_NM

__all__ = ["IndependentGenerator", "Truth", "SPREADS", "TIMELINE", "NESTS"]

SPREADS = {
    "compliance": 0.15,
    "K_c": 0.15,
    "s0": 15e-3,
    "mass_scale": 0.05,
    "load_point": 10e-3,
    "marker": 1e-3,
}
"""Spreads of the drawn truth: log-normal σ of each joint compliance, of K_c and of the link-mass
scale; normal σ (m) of s0, of each coordinate of the load point and of each marker coordinate.
Wider than the ±3σ widths Klimchik et al.'s Table IV reports (1-5 % for k2..k6), so that the
truth is not the configuration's."""

TIMELINE = {"marker": 20.0, "hang": 480.0, "unhang": 240.0, "move": 120.0}
"""Seconds between readings: of one marker and the next, from the unloaded reading to the
loaded one (hanging a load with a crane), from the loaded reading to the next repeat, and to the
next configuration.  ESTIMATES of a campaign's pace: Table III's 15 configurations × 3 repeats
take about 9 h."""

NESTS = {"N1": (2.5, 0.0, 0.0), "N2": (-1.25, 2.165, 0.0), "N3": (-1.25, -2.165, 0.0)}
"""Reference nests fixed on the floor (base frame, m): three 2.5 m from the base's axis, 120° apart.  ESTIMATES
of a cell's layout, spread around it as the practice is; read, 20 s apart, while the load is hung and unhung
(every 4-8 min of :data:`TIMELINE`)."""


@dataclass(frozen=True, eq=False)
class Truth:
    """What was true in a simulated campaign, and what a model criticism should say of it.

    Attributes
    ----------
    world : World
        The simulated world (SI).
    effect : str or None
        The planted effect's name.
    magnitude : float
    cause : str or None
        The cause family of the effect; None for an effect outside every family or no effect.
    expected : str
        ``"adequate"`` with no effect, else the cause family or ``"unexplained"``.
    jumped : numpy.ndarray
        (N, 2) bool: which unloaded and loaded readings jumped (outliers).
    nests : Nests or None
        The reference nests' readings, when asked for.
    """

    world: World
    effect: str | None
    magnitude: float
    cause: str | None
    jumped: np.ndarray = field(repr=False)
    nests: Nests | None = field(default=None, repr=False)

    @property
    def expected(self) -> str:
        """The verdict a model criticism should reach: adequate, a cause family, or unexplained."""
        if self.effect is None:
            return "adequate"
        return self.cause or "unexplained"

    def summary(self) -> pd.DataFrame:
        """The true parameters in the paper's units: one row each, columns ``value`` and ``unit``."""
        world = self.world
        rows = {f"k{j + 1}": (k / URAD_PER_NM, "μrad/(N·m)") for j, k in enumerate(world.compliances)}
        if world.linkage is not None:
            rows["K_c"] = (world.linkage.K_c / N_PER_MM, "N/mm")
            rows["s0"] = (world.linkage.s0 / MM, "mm")
            rows["progression"] = (world.linkage.progression, "1")
        rows["mass_scale"] = (world.mass_scale, "1")
        for axis, value in zip("xyz", world.load_point):
            rows[f"load_{axis}"] = (value / MM, "mm")
        frame = pd.DataFrame.from_dict(rows, orient="index", columns=["value", "unit"])
        frame.index.name = "parameter"
        return frame

    def to_json(self) -> str:
        """The summary, the effect and the expected verdict as a JSON object."""
        table = self.summary()
        return json.dumps(
            {
                "effect": self.effect,
                "magnitude": self.magnitude,
                "cause": self.cause,
                "expected": self.expected,
                "parameters": {name: {"value": float(row.value), "unit": row.unit} for name, row in table.iterrows()},
                "jumped_readings": int(self.jumped.sum()),
            }
        )


class IndependentGenerator:
    """Simulates campaigns of ``cell`` with this subpackage's own solver, truths, effects and noise.

    Parameters
    ----------
    cell
        The cell: robot, compliances, compensator, tool and tracker around which truths are drawn.
    rng
        The random generator: every draw (truth, effect, noise) comes from it, in a fixed order.
    truth
        ``"drawn"`` (default): truth and tool drawn around the cell's (:data:`SPREADS`);
        ``"config"``: the cell's values exactly.
    isotropic
        Use the cell's isotropic tracker noise instead of the anisotropic one.
    noise
        Add the tracker's random noise (False: exact readings, still with the planted
        readout effects; to measure what an effect changes).
    kinematic_errors
        Scale of the DH errors each world draws for its joints (:mod:`bayescal.twin.independent.geometry`,
        1: their realistic size); 0, the default: the URDF's geometry, and no draw.
    """

    def __init__(
        self, cell: Cell, rng: np.random.Generator, *, truth: str = "drawn", isotropic: bool = False, noise: bool = True,
        kinematic_errors: float = 0.0,
    ) -> None:
        if not (np.isfinite(kinematic_errors) and kinematic_errors >= 0):
            raise InputError(f"kinematic_errors must be a finite number >= 0, got {kinematic_errors}", column="kinematic_errors")
        if truth not in ("drawn", "config"):
            raise InputError(f"truth must be 'drawn' or 'config', got {truth!r}", column="truth")
        self.cell = cell
        self.rng = rng
        self.truth = truth
        self.readout = TrackerReadout(cell.tracker, isotropic=isotropic)
        self.noise = noise
        self.kinematic_errors = kinematic_errors

    def world(self, effect: str | None = None, magnitude: float = 1.0) -> World:
        """A world drawn for one campaign, with ``effect`` planted at ``magnitude`` times its default."""
        cell, rng = self.cell, self.rng
        linkage = None
        if cell.compensator is not None:
            c = cell.compensator
            linkage = SpringLinkage(cell.compensated_joint, c.L, c.a_x, c.a_y, c.phi, c.K_c, c.s0)
        world = World(cell.compliances.copy(), linkage, 1.0, cell.load_point.copy(), dict(cell.markers))
        if self.truth == "drawn":
            world = self._drawn(world)
        if self.kinematic_errors > 0:
            world = replace(world, geometry=GeometryErrors.draw(cell.robot.nq, rng, self.kinematic_errors))
        if effect is None:
            return world
        if effect not in EFFECTS:
            raise InputError(f"unknown effect {effect!r}; known: {', '.join(EFFECTS)}", column="effect")
        if not (np.isfinite(magnitude) and magnitude >= 0):
            raise InputError(f"the magnitude must be a finite number ≥ 0, got {magnitude}", column="magnitude")
        planted = EFFECTS[effect]
        try:
            return planted(planted.default * magnitude).plant(world, cell, rng)
        except ValueError as exc:
            raise InputError(f"cannot plant {effect!r} in {cell.source}: {exc}", column="effect") from None

    def _drawn(self, world: World) -> World:
        rng = self.rng
        linkage = world.linkage
        if linkage is not None:
            linkage = replace(
                linkage,
                K_c=linkage.K_c * float(np.exp(rng.normal(0.0, SPREADS["K_c"]))),
                s0=linkage.s0 + float(rng.normal(0.0, SPREADS["s0"])),
            )
        markers = {name: point + rng.normal(0.0, SPREADS["marker"], 3) for name, point in world.markers.items()}
        return replace(
            world,
            compliances=world.compliances * np.exp(rng.normal(0.0, SPREADS["compliance"], len(world.compliances))),
            linkage=linkage,
            mass_scale=float(np.exp(rng.normal(0.0, SPREADS["mass_scale"]))),
            load_point=world.load_point + rng.normal(0.0, SPREADS["load_point"], 3),
            markers=markers,
        )

    def simulate(
        self, plan: Plan, repeats: int = 3, effect: str | None = None, magnitude: float = 1.0, *, world: World | None = None,
        nests: bool = False,
    ) -> tuple[Campaign, Truth]:
        """A campaign of ``plan`` with ``repeats`` unloaded/loaded readings per configuration.

        ``world``: a world from :meth:`world` to measure again (one truth on several plans);
        by default one is drawn with ``effect`` planted at ``magnitude``.  ``nests``: also read the
        reference nests of :data:`NESTS` before the first configuration and after every repeat's unloaded and loaded
        readings (:attr:`Truth.nests`), after the campaign's readings so that the campaign is the same without them.

        Returns
        -------
        Campaign
            One row per marker per repeat per configuration (configurations numbered
            from 1 in plan order, repeats from 1), with the load point in its columns.
        Truth
            The world and the effect's expected cause.

        Raises
        ------
        InputError
            For an unknown effect, fewer than one repeat, or a configuration without equilibrium.
        """
        if repeats < 1:
            raise InputError(f"repeats must be at least 1, got {repeats}", column="repeats")
        world = self.world(effect, magnitude) if world is None else world
        true_states, times, keys, wrenches = self._true_positions(world, plan, repeats)
        readings, jumped = self._read(world, true_states.reshape(-1, 3), times.reshape(-1))
        readings = readings.reshape(true_states.shape)
        n_markers = len(world.markers)
        config, repeat = (np.repeat(np.array(column), n_markers) for column in zip(*keys))
        campaign = Campaign(
            config=config,
            repeat=repeat,
            marker=np.tile(np.array(list(world.markers)), len(keys)),
            q=plan.q[config - 1],
            wrench=wrenches[config - 1],
            p0=readings[:, 0].reshape(-1, 3),
            p1=readings[:, 1].reshape(-1, 3),
            lines=np.zeros(len(config), dtype=int),
            source="<independent generator>",
            load_point=np.tile(world.load_point, (len(config), 1)),
            times=times.reshape(-1, 2),
        )
        truth = Truth(world, effect, magnitude, EFFECTS[effect].cause if effect else None, jumped.reshape(-1, 2),
                      self._nests(world, times.reshape(len(keys), -1, 2)) if nests else None)
        return campaign, truth

    def _nests(self, world: World, times: np.ndarray) -> Nests:
        """The nests of :data:`NESTS` read one after another before the first repeat's readings and after each
        repeat's unloaded and loaded ones (``times``: (repeats, markers, 2) s, in campaign order), through the same
        readout as the markers."""
        names = list(NESTS)
        spacing = TIMELINE["marker"] * np.arange(1, len(names) + 1)
        starts = np.concatenate([[times[0, 0, 0] - spacing[-1] - TIMELINE["marker"]], times[:, -1, :].ravel()])
        visit_times = (starts[:, None] + spacing).ravel()
        points = np.tile(np.array(list(NESTS.values())), (len(starts), 1))
        readings, _ = self._read(world, points, visit_times)
        return Nests(np.tile(np.array(names), len(starts)), visit_times, readings, np.zeros(len(points), dtype=int),
                     "<independent generator>")

    def _true_positions(self, world: World, plan: Plan, repeats: int):
        """True marker positions (rows, 2, 3) m, reading times (rows, 2) s, (config, repeat) keys and (M, 6) wrenches.

        Rows run over configurations, repeats and markers in that order; the second
        axis is unloaded, loaded.
        """
        cell = self.cell
        robot = scaled_robot(cell.robot if world.geometry is None else world.geometry.robot(cell.robot), world.mass_scale)
        statics = Statics(robot, world.joint_law(), world.linkage)
        markers = np.array(list(world.markers.values()))
        offsets = TIMELINE["marker"] * np.arange(len(markers))
        base = [] if world.tool is None else [Load(np.array([0.0, 0.0, -world.tool.mass * cell.gravity]), world.tool.centre)]
        play, clock = np.zeros(robot.nq), 0.0
        if world.approach is not None:
            play, previous = world.approach.start(), world.approach.home
        states, times, keys, wrenches = [], [], [], []
        for number, (q, mass) in enumerate(zip(plan.q, plan.masses(cell.load_mass))):
            if world.approach is not None:
                # The robot moves to each configuration unloaded, from the previous one.
                play, previous = world.approach.arrive(play, previous, q), q
            force = np.array([0.0, 0.0, -mass * cell.gravity])
            rotation, _ = cell.robot.flange_pose(q)
            wrenches.append(np.concatenate([force, np.cross(rotation @ world.load_point, force)]))
            for repeat in range(repeats):
                point = world.load_point
                if world.load_jitter > 0:
                    point = point + self.rng.normal(0.0, world.load_jitter, 3)
                pair = []
                for loaded in (False, True):
                    load = force if loaded else np.zeros(3)
                    try:
                        theta, play = self._equilibrium(statics, world, q, base + [Load(load, point)], play)
                    except SolverError as exc:
                        raise InputError(str(exc), source=plan.source, line=int(plan.lines[number]) or None) from None
                    pair.append(self._markers(world, robot, q, q + theta + play, load, point, markers))
                states.append(np.stack(pair, axis=1))
                times.append(np.stack([clock + offsets, clock + TIMELINE["hang"] + offsets], axis=1))
                keys.append((number + 1, repeat + 1))
                clock += TIMELINE["hang"] + TIMELINE["unhang"]
            clock += TIMELINE["move"]
        return np.concatenate(states), np.concatenate(times), keys, np.array(wrenches)

    @staticmethod
    def _equilibrium(statics: Statics, world: World, q, loads, play):
        """Deflections and play of one state: the play moves first if the torque pushes it across."""
        theta, torque = statics.solve(q, loads, play)
        lost_motion = world.play if world.play is not None else world.approach
        if lost_motion is not None:
            play = lost_motion.update(play, torque)
            theta, _ = statics.solve(q, loads, play)
        return theta, play

    def _markers(self, world: World, robot, q, q_link, force, point, markers) -> np.ndarray:
        """(k, 3) true marker positions (m) with the links at ``q_link`` under the load ``force`` at ``point``."""
        positions = robot.point_position(q_link, markers)
        if world.beams is not None:
            positions += world.beams.displacements(robot, q_link, force, point, markers)
        if world.tool is not None:
            rotation, _ = robot.flange_pose(q_link)
            positions += world.tool.displacements(rotation, force, point, markers, self.cell.gravity)
        if world.field is not None:
            positions += np.linalg.norm(force) / world.field_force * world.field.value(q, markers)
        return positions

    def _read(self, world: World, points: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tracker's readings (k, 3) m of true ``points`` taken at ``times``, and which jumped (k,)."""
        tracker = self.cell.tracker.position
        if world.scale is not None:
            points = world.scale.apply(points, tracker)
        if world.drift is not None:
            points = world.drift.apply(points, times, tracker)
        readings = self.readout.read(points, self.rng) if self.noise else points
        if world.jumps is None:
            return readings, np.zeros(len(readings), dtype=bool)
        return world.jumps.apply(readings, tracker, self.rng)
