"""Optimal calibration plans (eq 40 under the constraints of eq 41): exchange, then continuous refinement.

A plan has ``angles`` distinct q2 angles with ``per_angle`` configurations
each, as the paper's Table III (five angles, three configurations).  The
optimiser

1. draws a large set of feasible candidate configurations (:mod:`bayescal.design.constraints`)
   on a grid of q2 angles, the other joints uniform within their limits, and
   computes each one's information matrix (:mod:`bayescal.design.criteria`);
2. from a random start, exchanges (Fedorov's idea, in the form of Cook and
   Nachtsheim's coordinate exchange) one configuration for the best candidate
   at the same q2, or moves a whole group to another q2 angle filled greedily,
   until a full pass improves nothing (:mod:`bayescal.design.exchange`);
3. refines the best plan continuously: random steps on a group's q2 or on one
   configuration's other joints, kept when the plan stays feasible and improves,
   with a step that shrinks from a few degrees to a tenth of one
   (:mod:`bayescal.design.refinement`);
4. repeats 2-3 from several random starts and keeps the best.

Every configuration carries the heaviest mass of the design's range (the
information of a configuration grows as the square of its load), or on a cell
whose end-effector applies loads in any direction, a force of ``F_max`` (and
a couple) in a direction the exchange and the refinement choose
(:mod:`bayescal.design.loads`).
"""

from __future__ import annotations

import math
import re
from collections import Counter
from functools import cache, cached_property

import numpy as np

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan, prismatic_flags
from bayescal.design.constraints import DesignSpace, Feasibility, load_design_space
from bayescal.design.criteria import (
    CRITERIA,
    configuration_designs,
    criterion_values,
    designs_information,
    test_pose_design,
)
from bayescal.design.exchange import Exchange
from bayescal.design.linearisation import ExactLinearisation
from bayescal.design.loads import free_candidates, load_sizes
from bayescal.design.plan_design import PlanDesign, PlanEvaluation
from bayescal.design.prediction import PlanPrediction, predict
from bayescal.design.progress import Progress, best_text
from bayescal.design.refinement import REFINE_STEPS, Refinement
from bayescal.errors import InputError
from bayescal.forked import forked_map
from bayescal.robot.batched import BatchedChain, Poses
from bayescal.robot.compensator import MIN_ANGLES
from bayescal.units import DEG

__all__ = ["PlanDesign", "PlanDesigner"]

ANGLE_STEP_DEG = 2.5
"""Spacing (deg) of the candidates' q2 grid: finer than any plan's angle separation, and refined afterwards."""

CANDIDATES_PER_ANGLE = 20
"""Feasible candidate configurations drawn at each q2 of the grid (about 1100 on the KR-270)."""

TRIES_PER_CANDIDATE = 60
"""Random draws allowed per wanted candidate before a q2 angle is declared unusable
(about one draw in ten is feasible in the KR-270 cell)."""

STARTS = 3
"""Random starts of the exchange; on the KR-270 their results differ by 1-3 % (docs/design.md)."""

DRAW_BLOCK = 16
"""Random draws checked together per wanted candidate (a block of ``DRAW_BLOCK × candidates`` draws at a q2 angle):
about one draw in ten is feasible in the KR-270 cell, so one block usually fills an angle."""


class PlanDesigner(Exchange, Refinement):
    """Designs calibration plans for a cell.

    Parameters
    ----------
    cell
        The cell: robot, tool, tracker noise, nominal stiffness, test pose.
    space
        Admissible loads and geometric limits; default :func:`load_design_space` of the cell.
    repeats
        Measurements of each configuration (the paper: 3).
    model
        The model the search scores plans with: ``"exact"``
        (:class:`~bayescal.design.linearisation.ExactLinearisation`, the identification's default model) or
        ``"linear"`` (eq 31; the search takes two fifths of the exact model's time, but on the KR-270 its
        test-pose optimum leaves 1.4 times the exact model's error, docs/design.md).
    """

    def __init__(self, cell: Cell, space: DesignSpace | None = None, *, repeats: int = 3, model: str = "exact") -> None:
        if repeats < 1:
            raise InputError(f"expected at least 1 repeat, got {repeats}", source="repeats")
        if model not in ("linear", "exact"):
            raise InputError(f"unknown model '{model}'; expected linear or exact", source="model")
        cell.robot.check_limits(cell.test_q, source=cell.source)
        self.cell = cell
        self.space = load_design_space(cell) if space is None else space
        self.repeats = repeats
        self.model = model
        self.feasibility = Feasibility(cell, self.space)
        self.mass = self.space.mass_range[1]
        self.free = not cell.loading.hanging_only
        self.force_size, self.couple_size = load_sizes(cell, self.mass)
        self._down = np.array([0.0, 0.0, -self.force_size, 0.0, 0.0, 0.0])
        robot = cell.robot
        j2 = cell.plan_joint
        self.q2_range = (float(robot.lower[j2]), float(robot.upper[j2]))

    # The exact model's finite differences take seconds: built on first use, not by the constructor.
    @cached_property
    def exact(self) -> ExactLinearisation:
        """The exact model linearised about the cell's values (central differences)."""
        return ExactLinearisation(self.cell)

    @cached_property
    def _exact_test_design(self) -> np.ndarray:
        return self.exact.test_design()

    @cached_property
    def _test_design(self) -> np.ndarray:
        return test_pose_design(self.cell)

    @cached_property
    def _chain(self) -> BatchedChain:
        return BatchedChain.of(self.cell.robot)

    # ----------------------------------------------------------------- scoring

    def information(self, q, mass: float, model: str | None = None) -> np.ndarray:
        """(p, p) information of one configuration measured :attr:`repeats` times (default: the search's model)."""
        q = np.asarray(q, dtype=float)[np.newaxis]
        return self.informations(q, self._wrenches(q, np.array([[0.0, 0.0, -mass * self.cell.gravity]]), np.zeros((1, 3))), model)[0]

    def informations(self, q: np.ndarray, wrench: np.ndarray, model: str | None = None, *, poses: Poses | None = None) -> np.ndarray:
        """``(N, p, p)`` information of ``N`` configurations ``(N, nq)`` under wrenches ``(N, 6)`` (flange origin, base axes,
        each force through the load point), each measured :attr:`repeats` times, all solved at once (default: the search's model;
        ``poses``: the frames of ``q``, when already computed)."""
        if (model or self.model) == "exact":
            design, sigma = self.exact.wrench_designs(q, wrench)
        else:
            design, sigma = configuration_designs(self.cell, q, wrench, chain=self._chain, poses=poses)
        return designs_information(design, sigma, self.repeats)

    def _wrenches(self, q: np.ndarray, force: np.ndarray, couple: np.ndarray, poses: Poses | None = None) -> np.ndarray:
        """``(N, 6)`` :meth:`Cell.wrench <bayescal.cell.config.Cell.wrench>` of ``N`` configurations at once."""
        rotation = (self._chain.poses(q) if poses is None else poses).flange_rotation
        force = np.broadcast_to(force, (len(q), 3))
        return np.concatenate([force, np.cross(np.einsum("nij,j->ni", rotation, self.cell.load_point), force) + couple], axis=1)

    def _forces(self, loads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Forces and couples ``(N, 3)`` of designed ``loads`` ``(N, 6)``: the heaviest mass hanging on a hanging-only cell."""
        if self.free:
            return loads[:, :3], loads[:, 3:]
        return np.tile([0.0, 0.0, -self.mass * self.cell.gravity], (len(loads), 1)), np.zeros((len(loads), 3))

    def _load_informations(self, q: np.ndarray, loads: np.ndarray, poses: Poses | None = None) -> np.ndarray:
        """``(N, p, p)`` information of configurations ``q`` under designed ``loads`` (:mod:`bayescal.design.loads`), the search's
        model (``poses``: the frames of ``q``, when already computed)."""
        force, couple = self._forces(loads)
        return self.informations(q, self._wrenches(q, force, couple, poses), poses=poses)

    def _violations(self, q: np.ndarray, loads: np.ndarray, *, solve: bool = True, poses: Poses | None = None) -> list[str | None]:
        """Why each configuration of ``q`` under its designed load is infeasible (None where feasible); the search's mass is in range.

        ``solve=False`` leaves out the loaded equilibrium's existence, ``poses`` are the frames of ``q`` when already
        computed (:meth:`Feasibility.violations_under`)."""
        return self.feasibility.violations_under(q, *self._forces(loads), solve=solve, poses=poses)

    def _equilibrium_violations(self, q: np.ndarray, loads: np.ndarray) -> list[str | None]:
        """Why each configuration of ``q`` has no loaded equilibrium under its designed load (None where it has one), solved together."""
        return self.feasibility.equilibrium_violations(q, *self._forces(loads))

    def evaluate(self, plan: Plan, model: str = "exact") -> PlanPrediction:
        """The prediction for any plan (its own masses or forces, or the cell's load where it has none)."""
        information = self.informations(plan.q, plan.wrenches(self.cell), model).sum(axis=0)
        design = self._exact_test_design if model == "exact" else self._test_design
        return predict(self.cell, information, test_design=design)

    def assess(self, plan: Plan, source: str = "") -> PlanEvaluation:
        """``plan`` (read from ``source``) scored with the exact and the linear model, with the configurations
        that break a constraint of the cell."""
        return PlanEvaluation(plan, self.evaluate(plan, "exact"), self.evaluate(plan, "linear"), self.repeats, self.violations(plan), source)

    def violations(self, plan: Plan) -> list[dict]:
        """The configurations of ``plan`` (numbered from 1) that break a constraint, and why."""
        found = []
        forces, couples = plan.forces(self.cell.load_mass, self.cell.gravity), plan.couples()
        for number, (q, mass) in enumerate(zip(plan.q, plan.masses(self.cell.load_mass)), start=1):
            if plan.force is None:
                reason = self.feasibility.violation(q, mass) or self.cell.loading.couple_violation(couples[number - 1])
            else:
                reason = self.feasibility.violation_under(q, forces[number - 1], couples[number - 1])
            if reason is not None:
                found.append({"config": number, "reason": reason})
        return found

    def _scores(self, information: np.ndarray, criterion: str, groups: np.ndarray | None = None) -> np.ndarray:
        design = self._exact_test_design if self.model == "exact" else self._test_design
        return criterion_values(self.cell, information, criterion, test_design=design, groups=groups)

    def _score(self, information: np.ndarray, criterion: str) -> float:
        return float(self._scores(information[np.newaxis], criterion)[0])

    # ----------------------------------------------------------------- requests

    def max_angles(self) -> int:
        """Most distinct q2 angles the joint range allows at the design's separation."""
        low, high = self.q2_range
        return int(math.floor((high - low) / self.space.min_separation + 1e-9)) + 1

    def check_request(self, angles: int, per_angle: int, criterion: str, *, candidates_per_angle: int = CANDIDATES_PER_ANGLE) -> None:
        """Raise the :class:`InputError` :meth:`optimise` would for a request no plan can meet, before any work.

        ``candidates_per_angle`` is the number of candidates the design will draw at each q2 angle: no plan takes more.
        """
        self._check_request(angles, per_angle, criterion)
        if per_angle > candidates_per_angle:
            raise InputError(
                f"expected at most {candidates_per_angle} configurations per q2 angle (the candidates the design draws at each), "
                f"got {per_angle}",
                source="per_angle",
            )

    def _check_request(self, angles: int, per_angle: int, criterion: str, *, scored: bool = True) -> None:
        if criterion not in CRITERIA:
            raise InputError(f"unknown criterion '{criterion}'; expected one of {', '.join(CRITERIA)}", source="criterion")
        if angles < 1:
            raise InputError(f"expected at least 1 angle, got {angles}", source="angles")
        if per_angle < 1:
            raise InputError(f"expected at least 1 configuration per angle, got {per_angle}", source="per_angle")
        if angles > self.max_angles():
            low, high = (math.degrees(v) for v in self.q2_range)
            raise InputError(
                f"{angles} q2 angles do not fit in the joint range {low:.0f} to {high:.0f} deg at "
                f"{math.degrees(self.space.min_separation):.0f} deg apart (at most {self.max_angles()})",
                source="angles",
            )
        # every criterion inverts the information in K_θ2^0 and the law's parameters, singular below three angles
        if self.cell.compensator is not None and angles < MIN_ANGLES and scored:
            names = ", ".join(p.name for p in self.cell.compensator.PARAMETERS[:-1])
            raise InputError(
                f"the compensator's K_θ2^0, {names} and {self.cell.compensator.PARAMETERS[-1].name} need at least {MIN_ANGLES} "
                f"distinct q2 angles, got {angles}",
                source="angles",
            )

    # ----------------------------------------------------------------- candidates

    def _grid(self) -> np.ndarray:
        low, high = self.q2_range
        count = int(math.floor((high - low) / (ANGLE_STEP_DEG * DEG) + 1e-9)) + 1
        return np.linspace(low, low + (count - 1) * ANGLE_STEP_DEG * DEG, count)

    def _random_configuration(self, q2: float, rng: np.random.Generator, tries: int, reasons: Counter) -> np.ndarray | None:
        found = self._random_configurations(q2, rng, 1, tries, reasons)
        return found[0] if found else None

    def _random_configurations(self, q2: float, rng: np.random.Generator, wanted: int, tries: int, reasons: Counter, *,
                               solve: bool = True) -> list[np.ndarray]:
        """Up to ``wanted`` feasible configurations at ``q2``, each from at most ``tries`` uniform draws; the first
        that finds none ends the search.  The draws are checked by blocks, and the random stream is left
        where drawing one configuration after another would leave it.  ``solve=False`` takes the loaded
        equilibrium to exist (:meth:`Feasibility.violations_under`): the caller solves it."""
        robot = self.cell.robot
        found: list[np.ndarray] = []
        failed = 0
        while True:
            state = rng.bit_generator.state
            block = rng.uniform(robot.lower, robot.upper, size=(DRAW_BLOCK * wanted, robot.nq))
            block[:, self.cell.plan_joint] = q2
            for used, reason in enumerate(self._violations(block, np.tile(self._down, (len(block), 1)), solve=solve), start=1):
                if reason is None:
                    found.append(block[used - 1])
                    failed = 0
                else:
                    failed += 1
                    reasons[_reason_kind(reason)] += 1
                if len(found) == wanted or failed == tries:
                    rng.bit_generator.state = state
                    rng.uniform(robot.lower, robot.upper, size=(used, robot.nq))
                    return found

    def candidates(self, rng: np.random.Generator, *, per_angle: int = CANDIDATES_PER_ANGLE, progress: bool = False):
        """Feasible candidates on the q2 grid: (n, nq) configurations, their grid index, information and (n, 6) loads.

        On an any-direction cell each configuration comes under :data:`~bayescal.design.loads.DIRECTIONS_PER_CONFIGURATION` loads.

        Raises
        ------
        InputError
            When no configuration is feasible (e.g. a tracker that sees no marker).
        """
        grid = self._grid()
        state = rng.bit_generator.state
        configurations, index, reasons = self._draw_candidates(grid, rng, per_angle, progress, solve=False)
        # The loaded equilibria of every angle's candidates in one solve, not one solve an angle: they all exist on a
        # usable cell, and where one does not, the draws are made again as the sequential search makes them.
        down = np.tile(self._down, (len(configurations), 1))
        if configurations and any(reason is not None for reason in self._equilibrium_violations(np.array(configurations), down)):
            rng.bit_generator.state = state
            configurations, index, reasons = self._draw_candidates(grid, rng, per_angle, progress, solve=True)
        if not configurations:
            common = reasons.most_common(1)[0][0] if reasons else "no draws"
            raise InputError(f"no feasible configuration found in the cell (most frequent reason: {common})", source=self.cell.source)
        configurations, index = np.array(configurations), np.array(index)
        if not self.free:
            loads = np.tile(self._down, (len(configurations), 1))
            return grid, configurations, index, self._load_informations(configurations, loads), loads
        exact = self.exact if self.model == "exact" else None
        return (grid, *free_candidates(self.cell, configurations, index, rng, self.force_size, self.couple_size, exact, self.repeats))

    def _draw_candidates(self, grid: np.ndarray, rng: np.random.Generator, per_angle: int, progress: bool, *,
                         solve: bool) -> tuple[list[np.ndarray], list[int], Counter]:
        """Each angle's :meth:`_random_configurations` in turn: the configurations, their grid index and why draws failed."""
        configurations, index, reasons = [], [], Counter()
        bar = Progress(len(grid), "plan: candidates", progress)
        for g, q2 in enumerate(grid):
            found = self._random_configurations(q2, rng, per_angle, TRIES_PER_CANDIDATE, reasons, solve=solve)
            configurations += found
            index += [g] * len(found)
            bar.step()
        bar.close()
        return configurations, index, reasons

    def random_plan(self, angles: int, per_angle: int, rng: np.random.Generator) -> Plan:
        """A random feasible plan: ``angles`` q2 values uniform over the range and apart, random other joints."""
        self._check_request(angles, per_angle, "d-optimal", scored=False)
        low, high = self.q2_range
        reasons: Counter = Counter()
        for _ in range(100):
            q2 = np.sort(rng.uniform(low, high, size=angles))
            if angles > 1 and np.min(np.diff(q2)) < self.space.min_separation:
                continue
            rows = []
            for value in q2:
                for _ in range(per_angle):
                    q = self._random_configuration(float(value), rng, TRIES_PER_CANDIDATE * 10, reasons)
                    if q is None:
                        break
                    rows.append(q)
            if len(rows) == angles * per_angle:
                return self._plan(np.array(rows), np.tile(self._down, (len(rows), 1)))
        raise InputError(f"no random feasible plan with {angles} angles found (most frequent reason: {reasons.most_common(1)})", source="angles")

    def _plan(self, q: np.ndarray, loads: np.ndarray) -> Plan:
        lines = np.zeros(len(q), dtype=int)
        prismatic = prismatic_flags(self.cell.robot)
        if not self.free:
            return Plan(q=q, load_kg=np.full(len(q), self.mass), lines=lines, source="optimised", prismatic=prismatic)
        return Plan(
            q=q, load_kg=None, lines=lines, source="optimised", force=loads[:, :3],
            couple=loads[:, 3:] if self.couple_size > 0 else None, prismatic=prismatic,
        )

    # ----------------------------------------------------------------- optimisation

    def optimise(
        self,
        angles: int = 5,
        per_angle: int = 3,
        criterion: str = "test-pose",
        rng: np.random.Generator | int | None = None,
        *,
        starts: int = STARTS,
        refine_steps: int = REFINE_STEPS,
        candidates_per_angle: int = CANDIDATES_PER_ANGLE,
        candidates: tuple | None = None,
        progress: bool = False,
        workers: int = 1,
    ) -> PlanDesign:
        """The best plan found for ``criterion`` (module docstring for the algorithm).

        Parameters
        ----------
        angles
            Distinct q2 angles.
        per_angle
            Configurations at each angle.
        criterion
            ``"test-pose"`` (eqs 38-40), ``"compensator"`` or ``"d-optimal"``.
        rng
            Random generator or seed; the same seed gives the same plan.
        starts
            Random starts of the exchange.
        refine_steps
            Proposals of the continuous refinement of each start (0: exchange only).
        candidates_per_angle
            Candidate configurations at each q2 of the grid.
        candidates
            A candidate set from :meth:`candidates` to reuse (studies that design many plans).
        progress
            Draw a progress bar on stderr.
        workers
            Processes forked to run the starts (:func:`~bayescal.forked.forked_map`): the plan is the same for any
            number; 1 runs them in this process, as a study that designs plans in parallel itself wants.

        Raises
        ------
        InputError
            For a request no plan can meet: an unknown criterion, more angles than the
            joint range allows, too few angles for the compensator, no feasible configuration.
        """
        seed = rng if isinstance(rng, int) else None
        rng = np.random.default_rng(rng)
        if candidates is None:
            self.check_request(angles, per_angle, criterion, candidates_per_angle=candidates_per_angle)
            candidates = self.candidates(rng, per_angle=candidates_per_angle, progress=progress)
        else:
            self._check_request(angles, per_angle, criterion)
        available, usable = _usable_angles(candidates[2], len(candidates[0]), angles, per_angle)
        # Every start's random draws first, as one start after another would draw them: the starts then depend on their
        # draws alone and can run in forked processes, with the plans of one process.
        drawn = [(self._start(candidates[0], usable, available, angles, per_angle, rng), self._moves(rng, refine_steps, angles, per_angle)) for _ in range(starts)]
        best, scores = self._best_start(lambda s: self._one_start(candidates, available, usable, per_angle, criterion, *drawn[s]), starts, criterion, workers, progress)
        return self._design(self._plan(best[0], best[1]), criterion, scores, len(candidates[1]), seed)

    def _best_start(self, start, starts: int, criterion: str, workers: int, progress: bool) -> tuple[tuple, list[float]]:
        """The best of ``start(0), ..., start(starts - 1)`` (each joints, loads and criterion value), run by
        ``workers`` processes, and every start's value."""
        bar = Progress(starts, f"plan: {criterion}", progress)
        best, scores = None, []
        law = [] if self.cell.compensator is None else [tuple(p.name for p in self.cell.compensator.PARAMETERS)]
        for q, load, score in forked_map(start, starts, workers):
            scores.append(score)
            if best is None or score < best[2]:
                best = (q, load, score)
            bar.step(best_text(best[2], criterion, *law))
        bar.close()
        return best, scores

    def _one_start(self, candidates: tuple, available: list[np.ndarray], usable: np.ndarray, per_angle: int, criterion: str,
                   groups: list, moves: list) -> tuple[np.ndarray, np.ndarray, float]:
        """One random start ``groups``: exchanged over the candidates, then refined by ``moves``; its joints, loads and criterion value."""
        grid, configurations, _, information, loads = candidates
        groups = self._exchange(groups, grid, usable, available, information, criterion)
        chosen = [c for group in groups for c in group[1]]
        return self._refine(configurations[chosen], loads[chosen], per_angle, criterion, moves)

    def _design(self, plan, criterion: str, scores: list[float], n_candidates: int, seed: int | None) -> PlanDesign:
        """The chosen plan with its predictions under both models and how the search found it."""
        return PlanDesign(
            plan=plan,
            criterion=criterion,
            prediction=self.evaluate(plan, "exact"),
            linear=self.evaluate(plan, "linear"),
            model=self.model,
            repeats=self.repeats,
            starts=scores,
            candidates=n_candidates,
            seed=seed,
            plan_joint=self.cell.plan_joint,
        )

    def _separated(self, values: list[float]) -> bool:
        # sorted and differenced in Python: a few angles, checked thousands of times a search
        values = sorted(float(v) for v in values)
        return len(values) < 2 or min(b - a for a, b in zip(values, values[1:])) >= self.space.min_separation - 1e-12


@cache
def _reason_kind(reason: str) -> str:
    """``reason`` without its angles, so that "marker M1 faces 97 deg away" and "... 120 deg away" count together
    (cached: a search counts thousands of failed draws, of a few hundred distinct reasons)."""
    return re.sub(r" -?\d+(\.\d+)? deg", "", reason.split(" (")[0])


def _usable_angles(index: np.ndarray, n_grid: int, angles: int, per_angle: int) -> tuple[list[np.ndarray], np.ndarray]:
    """The candidates at each q2 of the grid and which q2 have ``per_angle`` of them, refusing fewer than ``angles`` such q2."""
    available = [np.flatnonzero(index == g) for g in range(n_grid)]
    usable = np.array([len(c) >= per_angle for c in available])
    if np.count_nonzero(usable) < angles:
        # No angle with that many: the configurations per angle are at fault, not the number of angles.
        raise InputError(
            f"only {np.count_nonzero(usable)} q2 angles have {per_angle} feasible configurations, {angles} requested",
            source="angles" if usable.any() else "per_angle",
        )
    return available, usable
