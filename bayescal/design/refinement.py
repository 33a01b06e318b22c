"""Continuous refinement of a plan (step 3 of :mod:`bayescal.design.optimise`).

:class:`Refinement` is a part of :class:`~bayescal.design.optimise.PlanDesigner`, not used alone: its
methods read the designer's ``cell``, ``model``, ``free`` and ``_chain`` and call its ``_score``,
``_load_informations``, ``_violations``, ``_equilibrium_violations`` and ``_separated``.
"""

from __future__ import annotations

import numpy as np

from bayescal.design.loads import turn_draws, turned
from bayescal.robot.stiffness import EquilibriumError
from bayescal.units import DEG

__all__ = ["REFINE_BLOCK", "REFINE_STEPS", "REFINE_STEP_DEG", "Refinement"]

REFINE_STEPS = 200
"""Proposals of the continuous refinement of each start."""

REFINE_STEP_DEG = (3.0, 0.1)
"""First and last standard deviation (deg) of the refinement's random steps."""

REFINE_BLOCK = 32
"""Refinement steps looked ahead: the configurations they would propose from the current plan are solved together.
The steps are still taken one after another; one whose configuration was not foreseen (its row changed by an
accepted step) looks ahead again."""


class Refinement:
    """Random steps on a plan's q2 angles, other joints and load directions, kept when they improve it."""

    def _refine(self, q: np.ndarray, loads: np.ndarray, per_angle: int, criterion: str, moves: list):
        """The plan reached from ``q``, ``loads`` by the random steps ``moves`` (:meth:`_moves`), and its criterion."""
        # information of each configuration and load met so far, None when infeasible
        known: dict[bytes, np.ndarray | None] = {}
        # configurations and loads the linear model's look-ahead found feasible but for the loaded equilibrium, not yet solved
        unsolved: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        while True:
            result, taken = self._refine_steps(q, loads, per_angle, criterion, moves, known, unsolved)
            # The equilibria of the configurations the steps took, solved at once: they exist on a usable cell, and where
            # one does not, the steps are taken again from the start knowing it infeasible, as the first pass should have.
            taken = list(taken)
            reasons = self._equilibrium_violations(np.array([unsolved[key][0] for key in taken]), np.array([unsolved[key][1] for key in taken])) if taken else []
            for key, reason in zip(taken, reasons):
                del unsolved[key]
                if reason is not None:
                    known[key] = None
            if all(reason is None for reason in reasons):
                return result

    def _moves(self, rng: np.random.Generator, steps: int, angles: int, per_angle: int) -> list[tuple[str, np.ndarray, np.ndarray, object]]:
        """The random part of ``steps`` refinement steps of a plan of ``angles`` × ``per_angle`` configurations, drawn in
        order: for each, what it moves (``"angle"``, ``"turn"``, ``"joints"``), the rows and joints it changes, and the
        step: the joints' change (rad), or for a turn its size (rad) and :func:`~bayescal.design.loads.turn_draws`.

        A step's draws do not depend on the plan it moves, so a start's steps are drawn before its exchange and
        refinement run: the starts can then run apart (:meth:`~bayescal.design.optimise.PlanDesigner.optimise`), each
        leaving the random stream where the steps drawn one after another would."""
        j2 = self.cell.plan_joint
        others = np.array([j for j in range(self.cell.robot.nq) if j != j2])
        first, last = (v * DEG for v in REFINE_STEP_DEG)
        moves = []
        for step in range(steps):
            # the step's size shrinks geometrically from REFINE_STEP_DEG's first to its last
            size = first * (last / first) ** (step / max(steps - 1, 1))
            if rng.random() < 0.3:
                group = int(rng.integers(angles))
                moves.append(("angle", np.arange(group * per_angle, (group + 1) * per_angle), j2, rng.normal() * size))
            elif self.free and rng.random() < 0.5:
                row = np.array([int(rng.integers(angles * per_angle))])
                moves.append(("turn", row, None, (size, turn_draws((self.force_size, self.couple_size), rng))))
            else:
                row = np.array([int(rng.integers(angles * per_angle))])
                moves.append(("joints", row, others, rng.normal(size=len(others)) * size))
        return moves

    def _refine_steps(self, q, loads, per_angle, criterion, moves: list, known: dict, unsolved: dict):
        """The refinement's steps from the plan ``q``, ``loads``: the plan reached with its criterion, and the keys (a dict's
        keys, in order) of the configurations it took whose equilibrium is in ``unsolved``."""
        q, loads = q.copy(), loads.copy()
        parts = self._load_informations(q, loads)
        current = self._score(parts.sum(axis=0), criterion)
        taken: dict[bytes, None] = {}
        # one step after another, the configurations evaluated ahead in batches (a row a step does not change keeps its
        # evaluation)
        for step in range(len(moves)):
            proposal = self._proposal(q, loads, moves[step], per_angle)
            if proposal is None:
                continue
            moved, turn, rows = proposal
            keys = [_key(moved[r], turn[r]) for r in rows]
            if any(key not in known for key in keys):
                self._look_ahead(q, loads, moves[step : step + REFINE_BLOCK], per_angle, known, unsolved)
            if any(known[key] is None for key in keys):
                continue
            trial = parts.copy()
            for r, key in zip(rows, keys):
                trial[r] = known[key]
            score = self._score(trial.sum(axis=0), criterion)
            if score < current:
                q, loads, parts, current = moved, turn, trial, score
                taken.update((key, None) for key in keys if key in unsolved)
        return (q, loads, current), taken

    def _look_ahead(self, q, loads, moves: list, per_angle, known: dict, unsolved: dict) -> None:
        """Evaluate at once the configurations the steps ``moves`` (the next :data:`REFINE_BLOCK`) would propose from the plan ``q``, ``loads``.

        The linear model's information needs no equilibrium: the configurations that pass the other checks go to
        ``unsolved``, and their equilibria are solved for those a step takes (:meth:`_refine`)."""
        wanted: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        for move in moves:
            proposal = self._proposal(q, loads, move, per_angle)
            if proposal is not None:
                moved, turn, rows = proposal
                for r in rows:
                    key = _key(moved[r], turn[r])
                    if key not in known:
                        wanted[key] = (moved[r], turn[r])
        keys = list(wanted)
        new_q = np.array([wanted[key][0] for key in keys])
        new_loads = np.array([wanted[key][1] for key in keys])
        # the proposals' frames, once for the checks and the information
        poses = self._chain.poses(new_q)
        feasible = np.array([reason is None for reason in self._violations(new_q, new_loads, solve=False, poses=poses)], dtype=bool)
        information = None
        if self.model == "exact":
            # The exact designs solve each loaded equilibrium at the cell's values, the feasibility's last check: solved
            # once, unless one fails (then the feasibility finds which).
            try:
                information = self._load_informations(new_q[feasible], new_loads[feasible], poses.take(feasible)) if feasible.any() else []
            except EquilibriumError:
                information = None
        else:
            information = self._load_informations(new_q[feasible], new_loads[feasible], poses.take(feasible)) if feasible.any() else []
            unsolved.update((key, wanted[key]) for key, f in zip(keys, feasible) if f)
        if information is None:
            feasible = np.array([reason is None for reason in self._violations(new_q, new_loads)], dtype=bool)
            information = self._load_informations(new_q[feasible], new_loads[feasible]) if feasible.any() else []
        for key, value in zip([k for k, f in zip(keys, feasible) if f], information):
            known[key] = value
        known.update({key: None for key, f in zip(keys, feasible) if not f})

    def _proposal(self, q: np.ndarray, loads: np.ndarray, move: tuple, per_angle: int):
        """The step ``move`` (:meth:`_moves`) applied to the plan ``q``, ``loads``: the proposed configurations, loads and
        the rows changed, or None when it breaks the angles' separation."""
        kind, rows, joints, step = move
        proposal, turn = q.copy(), loads.copy()
        if kind == "turn":
            # the step (rad) turns the load's direction as far as it moves a joint
            turn[rows[0]] = turned(loads[rows[0]], *step)
        else:
            proposal[rows, joints] += step
            if kind == "angle" and not self._separated(list(proposal[::per_angle, self.cell.plan_joint])):
                return None
        return proposal, turn, rows


def _key(q: np.ndarray, load: np.ndarray) -> bytes:
    """A configuration and its load as a dictionary key (exact values)."""
    return q.tobytes() + load.tobytes()

