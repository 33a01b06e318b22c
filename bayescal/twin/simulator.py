"""The digital twin: simulated laser-tracker campaigns of a cell with known truth.

For each configuration of a plan the twin solves the nonlinear static
equilibrium of the arm (links' weights, compensator, joint springs) twice,
without and with the load at the tool's load point (a hanging mass, or a force
that keeps its direction in the base axes as one applied by a cable or a jack
does, and a couple: :mod:`bayescal.cell.loading`), places the tool's
markers at ``q + θ`` by forward kinematics, and lets the tracker read them with
fresh noise at every repeat.  Planted effects (:mod:`bayescal.twin.effects`) change
the compensator, the joint springs, add compliance outside the joints or
corrupt the readings.

With linear joint springs (no ``backlash`` or ``nonlinear_stiffness`` effect) a
campaign's equilibria are solved all at once (:func:`~bayescal.robot.batched.equilibria`)
and its readings drawn in one call, in the order one configuration after another draws them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from functools import cached_property

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.cell.nests import Nests
from bayescal.twin.drift import NESTS, TrackerDrift, nest_times, reading_times
from bayescal.twin.effects import EFFECTS, Effect
from bayescal.errors import InputError
from bayescal.cell.plan import Plan, prismatic_flags
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.stiffness import ElasticArm, EquilibriumError, LinearJoints

__all__ = ["DigitalTwin"]


class DigitalTwin:
    """A simulated calibration cell.

    Parameters
    ----------
    cell
        The cell (robot, stiffness, compensator, tool, tracker).
    effects
        Effects to plant, at most one of each kind.  The cell's compensator is on
        unless a ``compensator`` effect with magnitude 0 removes it.
    drift
        The tracker's drift in time (:mod:`bayescal.twin.drift`); its campaigns then carry their reading times.
    passes
        Timed campaigns measure the plan once per repeat (a configuration's repeats a pass apart), not a
        configuration's repeats one after another.
    """

    def __init__(self, cell: Cell, effects: Sequence[Effect] = (), drift: TrackerDrift | None = None, passes: bool = False) -> None:
        names = [effect.name for effect in effects]
        for name in names:
            if names.count(name) > 1:
                raise ValueError(f"effect '{name}' is given more than once")
        order = list(EFFECTS)
        self.cell = cell
        self.drift = drift
        self.passes = passes
        self.effects = tuple(sorted(effects, key=lambda effect: order.index(effect.name)))
        compensator = cell.compensator
        law = LinearJoints(cell.compliances)
        for effect in self.effects:
            compensator = effect.compensator(compensator)
            law = effect.joints(law, cell.robot)
        self.arm = ElasticArm(cell.robot, law, compensator=compensator, load_point=cell.load_point, compensated_joint=cell.compensated_joint)
        self.marker_names = tuple(cell.markers)
        self._points = np.array([cell.markers[name] for name in self.marker_names])

    def _deflections(self, q, wrench) -> np.ndarray:
        return self.arm.equilibrium(q, wrench)

    def positions(self, q, mass: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact marker positions (m, base frame, in :attr:`marker_names` order) unloaded and loaded with ``mass`` kg."""
        q = np.asarray(q, dtype=float)
        return self._positions(q, self.cell.load_wrench(q, mass))

    def positions_under(self, q, wrench) -> tuple[np.ndarray, np.ndarray]:
        """Like :meth:`positions`, under any (6,) ``wrench`` at the flange origin, base axes, its force through the load point."""
        return self._positions(np.asarray(q, dtype=float), np.asarray(wrench, dtype=float))

    def _positions(self, q: np.ndarray, wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        robot = self.cell.robot
        unloaded = robot.point_position(q + self._deflections(q, np.zeros(6)), self._points)
        theta = self._deflections(q, wrench)
        loaded = robot.point_position(q + theta, self._points)
        rotation, _ = robot.flange_pose(q)
        couple = wrench[3:] - np.cross(rotation @ self.cell.load_point, wrench[:3])
        for effect in self.effects:
            loaded = loaded + effect.displacement(robot, q + theta, self._points, wrench[:3], couple, self.cell.load_point)
        return unloaded, loaded

    @cached_property
    def _chain(self) -> BatchedChain:
        return BatchedChain.of(self.cell.robot)

    def _batched_positions(self, q: np.ndarray, wrenches: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """``(N, markers, 3)`` exact positions (m) unloaded and loaded of every configuration at once; None when
        the joint law is not linear or a configuration has no equilibrium (the caller then solves one at a time)."""
        if not isinstance(self.arm.joints, LinearJoints):
            return None
        n = len(q)
        rows = np.concatenate([q, q])
        try:
            theta = equilibria(
                self._chain, rows, np.concatenate([np.zeros_like(wrenches), wrenches]), self.arm.joints.compliances,
                compensator=self.arm.compensator, compensated_joint=self.arm.compensated_joint,
                load_point=self.cell.load_point, gravity=self.arm.gravity,
            )
        except EquilibriumError:
            return None
        poses = self._chain.poses(rows + theta)
        positions = np.stack([poses.points(point) for point in self._points], axis=1)
        unloaded, loaded = positions[:n], positions[n:]
        if any(type(effect).displacement is not Effect.displacement for effect in self.effects):
            rotation = self._chain.poses(q).flange_rotation
            for i in range(n):
                couple = wrenches[i, 3:] - np.cross(rotation[i] @ self.cell.load_point, wrenches[i, :3])
                for effect in self.effects:
                    loaded[i] = loaded[i] + effect.displacement(self.cell.robot, q[i] + theta[n + i], self._points, wrenches[i, :3], couple, self.cell.load_point)
        return unloaded, loaded

    def simulate(self, plan: Plan, repeats: int, rng: np.random.Generator) -> Campaign:
        """A campaign: every configuration of ``plan`` measured ``repeats`` times, unloaded then loaded.

        Rows are ordered by configuration, repeat and marker; each repeat reads both
        states with fresh tracker noise.  The wrench recorded is the load referred to
        the flange origin with the arm at its commanded angles (:meth:`Plan.wrenches`).
        With a drift, the rows carry their reading times and the drift moves them.
        """
        campaign = self._simulate(plan, repeats, rng)
        return campaign if self.drift is None else self._timed(campaign, repeats, rng)[0]

    def simulate_with_nests(self, plan: Plan, repeats: int, rng: np.random.Generator, at: np.ndarray | None = None) -> tuple[Campaign, Nests]:
        """A timed campaign (:meth:`simulate`) and the readings of the reference nests of :data:`~bayescal.twin.drift.NESTS`
        at the pace of :data:`~bayescal.twin.drift.TIMELINE`, both moved by the one drift (if any) of the campaign.
        ``at``: (configurations,) bool, where the nests are read (a plan's ``read_nests``); None: at every one."""
        return self._timed(self._simulate(plan, repeats, rng), repeats, rng, at)

    def _timed(self, campaign: Campaign, repeats: int, rng: np.random.Generator, at: np.ndarray | None = None) -> tuple[Campaign, Nests]:
        """The campaign stamped with its times and the nests read, with fresh noise, then both drifted."""
        n_markers = len(self.marker_names)
        times = reading_times(len(campaign) // (repeats * n_markers), repeats, n_markers, self.passes)
        visits = nest_times(times, len(NESTS), at)
        names = np.tile(np.array(list(NESTS)), len(visits))
        points = np.tile(np.array(list(NESTS.values())), (len(visits), 1))
        nests = self.cell.tracker.measure(points, rng)
        flat = times.reshape(-1, 2)
        readings = np.concatenate([campaign.p0, campaign.p1, nests])
        if self.drift is not None:
            readings = self.drift.apply(readings, np.concatenate([flat[:, 0], flat[:, 1], visits.ravel()]), self.cell.tracker.position, rng)
        n = len(campaign)
        timed = replace(campaign, p0=readings[:n], p1=readings[n : 2 * n], times=flat)
        return timed, Nests(names, visits.ravel(), readings[2 * n :], np.zeros(len(names), dtype=int), "simulated")

    def _simulate(self, plan: Plan, repeats: int, rng: np.random.Generator) -> Campaign:
        if repeats < 1:
            raise ValueError(f"expected at least 1 repeat, got {repeats}")
        q = np.asarray(plan.q, dtype=float)
        n, m = len(q), len(self.marker_names)
        # Plan.wrenches for all configurations at once: force through the load point and couple, arm at q
        forces, couples = plan.forces(self.cell.load_mass, self.cell.gravity), plan.couples()
        lever = np.einsum("nij,j->ni", self._chain.poses(q).flange_rotation, self.cell.load_point)
        wrenches = np.concatenate([forces, np.cross(lever, forces) + couples], axis=1)
        exact = self._batched_positions(q, wrenches)
        if exact is None:
            exact = np.empty((2, n, m, 3))
            for number, (qi, wrench, line) in enumerate(zip(q, wrenches, plan.lines), start=1):
                try:
                    exact[:, number - 1] = self._positions(qi, wrench)
                except EquilibriumError as exc:
                    load = plan.describe_load(number - 1, self.cell.load_mass)
                    raise InputError(f"the twin finds no static equilibrium under {load} ({exc})", source=plan.source, line=int(line) or None) from None
        # readings (configuration, repeat, unloaded / loaded, marker, xyz), drawn in that order
        states = np.stack(exact, axis=1)[:, np.newaxis]
        tracker = self.cell.tracker
        if all(type(effect).corrupt is Effect.corrupt for effect in self.effects):
            readings = np.broadcast_to(states, (n, repeats) + states.shape[2:])
            # every repeat reads the same points: their noise levels computed once, for the first
            sigma = np.broadcast_to(tracker.sigma(states)[..., np.newaxis], readings.shape)
            readings = readings + rng.normal(size=readings.shape) * sigma
        else:
            readings = np.empty((n, repeats) + states.shape[2:])
            for i in range(n):
                for r in range(repeats):
                    for state in range(2):
                        measured = tracker.measure(states[i, 0, state], rng)
                        for effect in self.effects:
                            measured = effect.corrupt(measured, rng)
                        readings[i, r, state] = measured
        per_row = repeats * m
        return Campaign(
            config=np.repeat(np.arange(1, n + 1), per_row),
            repeat=np.tile(np.repeat(np.arange(1, repeats + 1), m), n),
            marker=np.tile(np.array(self.marker_names, dtype=str), n * repeats),
            q=np.repeat(q, per_row, axis=0),
            wrench=np.repeat(wrenches, per_row, axis=0),
            p0=readings[:, :, 0].reshape(-1, 3),
            p1=readings[:, :, 1].reshape(-1, 3),
            lines=np.zeros(n * per_row, dtype=int),
            source="simulated",
            prismatic=prismatic_flags(self.cell.robot),
        )
