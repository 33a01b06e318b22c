"""Continuous refinement of a plan (step 3 of :mod:`bayescal.design.optimise`).

:class:`Refinement` is a part of :class:`~bayescal.design.optimise.PlanDesigner`, not used alone: its
methods read the designer's ``cell``, ``model``, ``free`` and ``_chain`` and call its ``_score``,
``_load_informations``, ``_violations``, ``_equilibrium_violations`` and ``_separated``.
"""

from __future__ import annotations

import numpy as np

from bayescal.design.loads import turned
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

    def _refine(self, q: np.ndarray, loads: np.ndarray, angles: int, per_angle: int, criterion: str, rng: np.random.Generator, steps: int):
        # information of each configuration and load met so far, None when infeasible
        known: dict[bytes, np.ndarray | None] = {}
        # configurations and loads the linear model's look-ahead found feasible but for the loaded equilibrium, not yet solved
        unsolved: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        begin = rng.bit_generator.state
        while True:
            result, taken = self._refine_steps(q, loads, angles, per_angle, criterion, rng, steps, known, unsolved)
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
            rng.bit_generator.state = begin

    def _refine_steps(self, q, loads, angles, per_angle, criterion, rng, steps, known: dict, unsolved: dict):
        """The refinement's steps from the plan ``q``, ``loads``: the plan reached with its criterion, and the keys (a dict's
        keys, in order) of the configurations it took whose equilibrium is in ``unsolved``."""
        q, loads = q.copy(), loads.copy()
        parts = self._load_informations(q, loads)
        current = self._score(parts.sum(axis=0), criterion)
        taken: dict[bytes, None] = {}
        # one step after another as drawn, the configurations evaluated ahead in batches (a row a step does not change
        # keeps its evaluation)
        for step in range(steps):
            before = rng.bit_generator.state
            proposal = self._proposal(q, loads, step, steps, angles, per_angle, rng)
            if proposal is None:
                continue
            moved, turn, rows = proposal
            keys = [_key(moved[r], turn[r]) for r in rows]
            if any(key not in known for key in keys):
                after = rng.bit_generator.state
                rng.bit_generator.state = before
                self._look_ahead(q, loads, step, steps, angles, per_angle, rng, known, unsolved)
                rng.bit_generator.state = after
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

    def _look_ahead(self, q, loads, step, steps, angles, per_angle, rng, known: dict, unsolved: dict) -> None:
        """Evaluate at once the configurations the next :data:`REFINE_BLOCK` steps would propose from the plan ``q``, ``loads``.

        The linear model's information needs no equilibrium: the configurations that pass the other checks go to
        ``unsolved``, and their equilibria are solved for those a step takes (:meth:`_refine`)."""
        wanted: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        for s in range(step, min(step + REFINE_BLOCK, steps)):
            proposal = self._proposal(q, loads, s, steps, angles, per_angle, rng)
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

    def _proposal(self, q: np.ndarray, loads: np.ndarray, step: int, steps: int, angles: int, per_angle: int, rng: np.random.Generator):
        """Refinement step ``step``'s proposal from the plan ``q``, ``loads``: the proposed configurations, loads and
        the rows changed, or None when it breaks the angles' separation."""
        robot = self.cell.robot
        j2 = self.cell.plan_joint
        first, last = (v * DEG for v in REFINE_STEP_DEG)
        others = [j for j in range(robot.nq) if j != j2]
        size = first * (last / first) ** (step / max(steps - 1, 1))
        proposal, turn = q.copy(), loads.copy()
        if rng.random() < 0.3:
            group = int(rng.integers(angles))
            rows = np.arange(group * per_angle, (group + 1) * per_angle)
            proposal[rows, j2] += rng.normal() * size
            if not self._separated(list(proposal[::per_angle, j2])):
                return None
        elif self.free and rng.random() < 0.5:
            # the step (rad) turns the load's direction as far as it moves a joint
            rows = np.array([int(rng.integers(len(q)))])
            turn[rows[0]] = turned(loads[rows[0]], size, rng)
        else:
            rows = np.array([int(rng.integers(len(q)))])
            proposal[rows[0], others] += rng.normal(size=len(others)) * size
        return proposal, turn, rows


def _key(q: np.ndarray, load: np.ndarray) -> bytes:
    """A configuration and its load as a dictionary key (exact values)."""
    return q.tobytes() + load.tobytes()

