"""The discriminating plan's search: Fedorov's exchange on the worse of two candidates' separations.

:class:`_Exchange` is :class:`~bayescal.design.discriminate.DiscriminatingDesigner`'s search over its
candidate options, each a configuration at one mass; it scores a plan by
:func:`~bayescal.design.separation.separation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bayescal.design.separation import ranked_fits, separation, separation_bound
from bayescal.errors import InputError

__all__ = ["MAX_PASSES"]

MAX_PASSES = 10
"""Exchange passes at most; on the KR-270 a start settles in 2 to 4 passes."""

RANKED_OUTRIGHT = 32
"""Options ranked all in one batch rather than bounded first: one plan's fits and bound and two more batches (the
best-bounded option, those that reach it) took as long as one batch of 30 to 70 options on the KR-270."""

BOUND_MARGIN = 1e-9
"""Relative margin by which a bound (:func:`~bayescal.design.separation.separation_bound`) must fall short of an option's
ranked separation for the option to be left unranked, or of the plan's for a move's angle to be left unfilled: far
above the rounding of either (about 10⁻¹⁵), and far below what the bound exceeds the ranked separation by (at least
5 × 10⁻⁸ of it over the 99,000 options ranked in the 5 × 12 searches between backlash and nonlinear_stiffness, and
backlash and compensator, on the tie of docs/critique.md)."""


@dataclass
class _Exchange:
    """Fedorov's exchange on the worse of the two separations (:func:`separation`), configurations grouped by their q2 grid angle.

    Within a group the plan joint is not driven, so the side of its lost motion
    is set by the loads alone: the slots of a group alternate the side its loaded
    torque takes (``side``, per option), so that measured in slot order every
    configuration's first loading reverses the previous one's, whatever friction
    holds the joint and however it arrived.  A group short of one side fills the
    slots of that side from the other.
    """

    information: np.ndarray
    group: np.ndarray
    side: np.ndarray
    grid: np.ndarray
    separation_rad: float
    blocks: tuple
    beta: tuple
    rng: np.random.Generator
    # this search's own memory: the greedy fills already computed for a plan's other groups
    _filled: dict = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        # each q2 group's options in increasing order, those of each side as lists (for the pools' membership tests),
        # their information flat for the bounds, and each option's place in its group
        self._by_angle = {int(g): np.flatnonzero(self.group == g) for g in np.unique(self.group)}
        self._sides = {
            g: tuple([o for o in options.tolist() if self.side[o] == wanted] for wanted in (1.0, -1.0)) + (options.tolist(),)
            for g, options in self._by_angle.items()
        }
        self._flat = {g: self.information[options].reshape(len(options), -1) for g, options in self._by_angle.items()}
        self._place = np.zeros(len(self.group), dtype=int)
        for options in self._by_angle.values():
            self._place[options] = np.arange(len(options))

    def score(self, fixed: list[int], candidates: np.ndarray) -> np.ndarray:
        """(P,) the worse separation (nats) of the plan ``fixed`` with each of the P ``candidates`` added."""
        total = self.information[np.asarray(fixed, dtype=int)].sum(axis=0) + self.information[np.asarray(candidates, dtype=int)]
        return separation(total, self.blocks, *self.beta).min(axis=-1)

    def _best(
        self, partials: np.ndarray, angles: list[int], pools: list[np.ndarray], fits: np.ndarray | None = None
    ) -> tuple[list[int], list[float], np.ndarray]:
        """For each of K ``pools`` (of q2 groups ``angles``), the option whose plan ranks first when added to its plan of
        information ``partials`` (K, p, p): the first best by :func:`~bayescal.design.separation.ranked_separation`
        of every option, ranked only where it can be.

        Returns the K options, their plans' worse ranked separations (nats) and those plans' fits (K, 2, p)
        (:func:`~bayescal.design.separation.ranked_fits`).  ``fits`` are the partial plans' own, computed if not
        given, from which each option's bound is taken (:func:`~bayescal.design.separation.separation_bound`).
        """
        sizes = [len(pool) for pool in pools]
        edges = np.concatenate([[0], np.cumsum(sizes)])
        options, owner = np.concatenate(pools), np.repeat(np.arange(len(pools)), sizes)
        if len(options) <= RANKED_OUTRIGHT:
            # every option ranked, in one batch as before (a batch of one rounds its own way)
            ranked, directions = ranked_fits(partials[owner] + self.information[options], self.blocks, *self.beta)
            ranked = ranked.min(axis=-1)
        else:
            if fits is None:
                fits = ranked_fits(partials, self.blocks, *self.beta)[1]
            ranked, directions = self._bounded(partials, fits, angles, pools, edges)
        best = _first_best(ranked, edges)
        return options[best].tolist(), ranked[best].tolist(), directions[best]

    def _bounded(
        self, partials: np.ndarray, fits: np.ndarray, angles: list[int], pools: list[np.ndarray], edges: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """(N,) the worse ranked separation of the pools' options that can be the best of their pool, -inf for the
        others, and their plans' fits (N, 2, p): the option of each pool with the highest bound is ranked, then those
        whose bound reaches its value.  An option left out falls short of the best: its plan can neither be the best
        nor tie with it."""
        options, owner = np.concatenate(pools), np.repeat(np.arange(len(pools)), np.diff(edges))
        constant, weights = separation_bound(partials, fits, self.blocks)
        weights = weights.reshape(len(pools), 2, -1)
        added = np.concatenate([(self._flat[int(angle)] @ w.T)[self._place[pool]] for angle, pool, w in zip(angles, pools, weights)])
        bound = (0.5 * np.maximum(constant[owner] + added, 0.0)).min(axis=-1)
        # the fits of the options ranked; the others' are never read
        ranked, directions = np.full(len(options), -np.inf), np.empty((len(options),) + fits.shape[1:])
        first = _first_best(bound, edges)
        ranked[first], directions[first] = self._ranked(partials, options[first])
        reach = np.flatnonzero((bound >= ranked[first][owner] * (1 - BOUND_MARGIN)) & np.isneginf(ranked))
        if reach.size:
            ranked[reach], directions[reach] = self._ranked(partials[owner[reach]], options[reach])
        return ranked, directions

    def _ranked(self, partials: np.ndarray, options: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N,) the worse :func:`~bayescal.design.separation.ranked_separation` (nats) of each plan ``partials`` (N, p, p)
        with option ``options`` (N,) added, as ranked in a batch of several (a lone option is ranked beside a copy of
        itself), and the plans' fits (N, 2, p)."""
        total = self.information[np.repeat(options, 2) if len(options) == 1 else options]
        # added in place: the same sums, without another array of the batch's size
        total += partials
        ranked, directions = ranked_fits(total, self.blocks, *self.beta)
        return ranked.min(axis=-1)[: len(options)], directions[: len(options)]

    def value(self, chosen: list[int]) -> float:
        return float(self.score(chosen[:-1], chosen[-1:])[0])

    def _separated(self, angles: list[int]) -> bool:
        values = np.sort(self.grid[angles])
        return len(values) < 2 or bool(np.min(np.diff(values)) >= self.separation_rad - 1e-12)

    def _slot_pool(self, angle: int, slot: int, taken: list[int]) -> np.ndarray:
        """The options of q2 group ``angle`` free for ``slot``: those whose load takes the plan joint to the slot's side.

        Even slots take a positive torque, odd slots a negative one: the groups are
        measured in increasing q2, so the plan joint arrives at each driven up, its
        link lagging on the side a negative torque takes it to, and a group of even
        size leaves it there too.
        """
        positive, negative, every = self._sides.get(int(angle), ([], [], []))
        # a list's membership: a few options against a few taken, 41,712 times in the 5 × 12 search
        wanted = [option for option in (positive if slot % 2 == 0 else negative) if option not in taken]
        return np.array(wanted or [option for option in every if option not in taken], dtype=int)

    def _options(self, angle: int) -> np.ndarray:
        """The options of q2 group ``angle``, in increasing order."""
        return self._by_angle.get(int(angle), np.empty(0, dtype=int))

    def _fill(self, angle: int, per_angle: int) -> list[int]:
        """``per_angle`` options of group ``angle`` drawn at random, slot by slot (each slot's side first)."""
        members: list[int] = []
        for slot in range(per_angle):
            members.append(int(self.rng.choice(self._slot_pool(angle, slot, members))))
        return members

    def run(self, angles: int, per_angle: int) -> tuple[list[int], float]:
        usable = [g for g in range(len(self.grid)) if np.count_nonzero(self.group == g) >= per_angle]
        if len(usable) < angles:
            # No angle with that many: the configurations per angle are at fault, not the number of angles.
            raise InputError(
                f"only {len(usable)} q2 angles have {per_angle} feasible configurations, {angles} requested",
                source="angles" if usable else "per_angle",
            )
        for _ in range(1000):
            chosen_angles = list(self.rng.choice(usable, size=angles, replace=False))
            if self._separated(chosen_angles):
                break
        else:
            raise InputError(f"no {angles} q2 angles {math.degrees(self.separation_rad):.0f} deg apart have feasible configurations", source="angles")
        groups = [self._fill(int(g), per_angle) for g in chosen_angles]
        current = self.value(_flat(groups))
        for _ in range(MAX_PASSES):
            improved = False
            for g, members in enumerate(groups):
                for slot in range(per_angle):
                    pool = self._slot_pool(chosen_angles[g], slot, members)
                    if not pool.size:
                        continue
                    rest = _flat(groups[:g]) + members[:slot] + members[slot + 1 :] + _flat(groups[g + 1 :])
                    partial = self.information[np.asarray(rest, dtype=int)].sum(axis=0)
                    option, ranked, _ = self._best(partial[np.newaxis], [chosen_angles[g]], [pool])
                    if ranked[0] > current * (1 + 1e-9):
                        members[slot], improved = option[0], True
                        # kept: separation()'s value of this plan, not the ranking's, as the fills' (the starts are compared by it)
                        current = float(self.score(rest, [members[slot]])[0])
                moved = self._move(groups, chosen_angles, g, current)
                if moved is not None:
                    chosen_angles[g], groups[g], current, improved = moved[0], moved[1], moved[2], True
            if not improved:
                break
        return _flat(groups), current

    def _move(self, groups, chosen_angles, g, current):
        """The best other q2 angle for group ``g``, filled greedily, when it beats ``current``.

        Only the angles whose fill could beat it are filled (:meth:`_fill_bounds`): the others' fills could not be
        the best, nor tie with it.
        """
        rest = _flat(groups[:g] + groups[g + 1 :])
        others = chosen_angles[:g] + chosen_angles[g + 1 :]
        angles = [
            int(angle) for angle in np.unique(self.group)
            if angle != chosen_angles[g] and self._separated(others + [int(angle)]) and len(self._options(angle)) >= len(groups[g])
        ]
        # The fills depend only on the other groups: unchanged since the last pass, they are not computed again.
        key = (tuple(angles), len(groups[g]), tuple(rest))
        if key not in self._filled:
            self._filled[key] = (self._fill_bounds(angles, len(groups[g]), rest), {})
        bounds, fills = self._filled[key]
        wanted = [angle for angle in angles if angle not in fills and bounds[angle] * (1 + BOUND_MARGIN) >= current]
        if len(wanted) == 1 and len(angles) > 1:
            # filled beside another angle: a batch of one rounds its separation otherwise than a batch of several
            wanted += ([angle for angle in angles if angle not in fills and angle != wanted[0]] or [a for a in angles if a != wanted[0]])[:1]
        if wanted:
            fills.update(zip(wanted, self._greedy_fills(wanted, len(groups[g]), rest)))
        best = None
        for angle in (angle for angle in angles if angle in fills):
            members, score = fills[angle]
            if score > current * (1 + 1e-9) and (best is None or score > best[2]):
                best = (angle, list(members), score)
        return best

    def _fill_bounds(self, angles: list[int], size: int, fixed: list[int]) -> dict[int, float]:
        """Each of ``angles``' bound on the worse separation (nats) of plan ``fixed`` with ``size`` of its options added,
        whichever they are: :func:`~bayescal.design.separation.separation_bound` of the options' sum, with the
        ``size`` largest of the group's terms (each of A and B true)."""
        partial = self.information[np.asarray(fixed, dtype=int)].sum(axis=0)[np.newaxis]
        constant, weights = separation_bound(partial, ranked_fits(partial, self.blocks, *self.beta)[1], self.blocks)
        weights = weights.reshape(2, -1)
        return {
            angle: float((0.5 * np.maximum(constant[0] + np.sort(self._flat[angle] @ weights.T, axis=0)[-size:].sum(axis=0), 0.0)).min())
            for angle in angles
        }

    def _greedy_fills(self, angles: list[int], per_angle: int, fixed: list[int]) -> list[tuple[list[int], float]]:
        """Every group of ``angles`` filled slot by slot, each the best option added to ``fixed``, the groups scored together, and the
        worse separation (nats) of each filled plan.  The plans' information is summed in the order of
        :meth:`score`'s, member after member, so that the scores are those of one angle after another."""
        members: list[list[int]] = [[] for _ in angles]
        partial = np.repeat(self.information[np.asarray(fixed, dtype=int)].sum(axis=0)[np.newaxis], len(angles), axis=0)
        # the fits of each angle's plan so far, ranked with it: the next slot's bounds start from them
        fits = None
        for slot in range(per_angle):
            pools = [self._slot_pool(angle, slot, chosen) for angle, chosen in zip(angles, members)]
            chosen_now, _, fits = self._best(partial, angles, pools, fits)
            for k, choice in enumerate(chosen_now):
                members[k].append(choice)
                if slot < per_angle - 1:
                    partial[k] = partial[k] + self.information[choice]
        # the last member added to the others' sum, as value() adds it
        last = np.array([chosen[-1] for chosen in members], dtype=int)
        final = separation(partial + self.information[last], self.blocks, *self.beta).min(axis=-1)
        return [(chosen, float(score)) for chosen, score in zip(members, final)]


def _flat(groups: list[list[int]]) -> list[int]:
    return [o for members in groups for o in members]


def _first_best(values: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """The index of the first largest of ``values`` between each two consecutive ``edges`` (none of them empty), as ``np.argmax`` of each."""
    top = np.repeat(np.maximum.reduceat(values, edges[:-1]), np.diff(edges))
    return np.minimum.reduceat(np.where(values == top, np.arange(len(values)), len(values)), edges[:-1])
