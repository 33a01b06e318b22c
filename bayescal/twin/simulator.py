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
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.twin.effects import EFFECTS, Effect
from bayescal.errors import InputError
from bayescal.cell.plan import Plan, prismatic_flags
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
    """

    def __init__(self, cell: Cell, effects: Sequence[Effect] = ()) -> None:
        names = [effect.name for effect in effects]
        for name in names:
            if names.count(name) > 1:
                raise ValueError(f"effect '{name}' is given more than once")
        order = list(EFFECTS)
        self.cell = cell
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

    def simulate(self, plan: Plan, repeats: int, rng: np.random.Generator) -> Campaign:
        """A campaign: every configuration of ``plan`` measured ``repeats`` times, unloaded then loaded.

        Rows are ordered by configuration, repeat and marker; each repeat reads both
        states with fresh tracker noise.  The wrench recorded is the load referred to
        the flange origin with the arm at its commanded angles (:meth:`Plan.wrenches`).
        """
        if repeats < 1:
            raise ValueError(f"expected at least 1 repeat, got {repeats}")
        wrenches = plan.wrenches(self.cell)
        n_markers = len(self.marker_names)
        rows = {"config": [], "repeat": [], "marker": [], "q": [], "wrench": [], "p0": [], "p1": []}
        for number, (q, wrench, line) in enumerate(zip(plan.q, wrenches, plan.lines), start=1):
            try:
                unloaded, loaded = self._positions(q, wrench)
            except EquilibriumError as exc:
                load = plan.describe_load(number - 1, self.cell.load_mass)
                raise InputError(f"the twin finds no static equilibrium under {load} ({exc})", source=plan.source, line=int(line) or None) from None
            for repeat in range(1, repeats + 1):
                readings = []
                for exact in (unloaded, loaded):
                    measured = self.cell.tracker.measure(exact, rng)
                    for effect in self.effects:
                        measured = effect.corrupt(measured, rng)
                    readings.append(measured)
                rows["config"] += [number] * n_markers
                rows["repeat"] += [repeat] * n_markers
                rows["marker"] += list(self.marker_names)
                rows["q"] += [q] * n_markers
                rows["wrench"] += [wrench] * n_markers
                rows["p0"].append(readings[0])
                rows["p1"].append(readings[1])
        return Campaign(
            config=np.array(rows["config"], dtype=int),
            repeat=np.array(rows["repeat"], dtype=int),
            marker=np.array(rows["marker"], dtype=str),
            q=np.array(rows["q"], dtype=float),
            wrench=np.array(rows["wrench"], dtype=float),
            p0=np.vstack(rows["p0"]),
            p1=np.vstack(rows["p1"]),
            lines=np.zeros(len(rows["config"]), dtype=int),
            source="simulated",
            prismatic=prismatic_flags(self.cell.robot),
        )
