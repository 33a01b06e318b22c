"""The discriminating plan's search: Fedorov's exchange on the worse of two candidates' separations.

:class:`_Exchange` is :class:`~bayescal.design.discriminate.DiscriminatingDesigner`'s search over its
candidate options, each a configuration at one mass; it scores a plan by
:func:`~bayescal.design.separation.separation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bayescal.design.separation import ranked_separation, separation
from bayescal.errors import InputError

__all__ = ["MAX_PASSES"]

MAX_PASSES = 10
"""Exchange passes at most; on the KR-270 a start settles in 2 to 4 passes."""


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
    # this search's own memory: each q2 group's options, and the greedy fills already computed for a plan's other groups
    _by_angle: dict = field(default_factory=dict, init=False)
    _filled: dict = field(default_factory=dict, init=False)

    def score(self, fixed: list[int], candidates: np.ndarray, separated=separation) -> np.ndarray:
        """(P,) the worse separation (nats) of the plan ``fixed`` with each of the P ``candidates`` added, by ``separated``
        (:func:`~bayescal.design.separation.ranked_separation` to rank them)."""
        total = self.information[np.asarray(fixed, dtype=int)].sum(axis=0) + self.information[np.asarray(candidates, dtype=int)]
        return separated(total, self.blocks, *self.beta).min(axis=-1)

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
        options = self._options(angle)
        if taken:
            # a list's membership, not np.isin: a few options against a few taken, 31,128 times in the 5 × 12 search
            options = options[[option not in taken for option in options.tolist()]]
        wanted = options[self.side[options] == (1.0 if slot % 2 == 0 else -1.0)]
        return wanted if wanted.size else options

    def _options(self, angle: int) -> np.ndarray:
        """The options of q2 group ``angle``, in increasing order."""
        if not self._by_angle:
            self._by_angle.update({int(g): np.flatnonzero(self.group == g) for g in np.unique(self.group)})
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
                    scores = self.score(rest, pool, ranked_separation)
                    if scores.max() > current * (1 + 1e-9):
                        members[slot], improved = int(pool[np.argmax(scores)]), True
                        # kept: separation()'s value of this plan, not the ranking's, as the fills' (the starts are compared by it)
                        current = float(self.score(rest, [members[slot]])[0])
                moved = self._move(groups, chosen_angles, g, current)
                if moved is not None:
                    chosen_angles[g], groups[g], current, improved = moved[0], moved[1], moved[2], True
            if not improved:
                break
        return _flat(groups), current

    def _move(self, groups, chosen_angles, g, current):
        """The best other q2 angle for group ``g``, filled greedily, when it beats ``current``."""
        rest = _flat(groups[:g] + groups[g + 1 :])
        others = chosen_angles[:g] + chosen_angles[g + 1 :]
        angles = [
            int(angle) for angle in np.unique(self.group)
            if angle != chosen_angles[g] and self._separated(others + [int(angle)]) and len(self._options(angle)) >= len(groups[g])
        ]
        # The fills depend only on the other groups: unchanged since the last pass, they are not computed again.
        key = (tuple(angles), len(groups[g]), tuple(rest))
        if key not in self._filled:
            self._filled[key] = self._greedy_fills(angles, len(groups[g]), rest)
        best = None
        for angle, (members, score) in zip(angles, self._filled[key]):
            if score > current * (1 + 1e-9) and (best is None or score > best[2]):
                best = (angle, list(members), score)
        return best

    def _greedy_fills(self, angles: list[int], per_angle: int, fixed: list[int]) -> list[tuple[list[int], float]]:
        """Every group of ``angles`` filled slot by slot, each the best option added to ``fixed``, the groups scored together, and the
        worse separation (nats) of each filled plan.  The plans' information is summed in the order of
        :meth:`score`'s, member after member, so that the scores are those of one angle after another."""
        members: list[list[int]] = [[] for _ in angles]
        partial = np.repeat(self.information[np.asarray(fixed, dtype=int)].sum(axis=0)[np.newaxis], len(angles), axis=0)
        for slot in range(per_angle):
            pools = [self._slot_pool(angle, slot, chosen) for angle, chosen in zip(angles, members)]
            starts = np.concatenate([[0], np.cumsum([len(pool) for pool in pools])])
            # each angle's sum added in place to its candidates' information: the same sums as gathering a copy of
            # it per candidate first, in a quarter of the time
            total = self.information[np.concatenate(pools)]
            for k in range(len(angles)):
                total[starts[k] : starts[k + 1]] += partial[k]
            scores = ranked_separation(total, self.blocks, *self.beta).min(axis=-1)
            for k, pool in enumerate(pools):
                choice = int(pool[np.argmax(scores[starts[k] : starts[k + 1]])])
                members[k].append(choice)
                if slot < per_angle - 1:
                    partial[k] = partial[k] + self.information[choice]
        # the last member added to the others' sum, as value() adds it
        last = np.array([chosen[-1] for chosen in members], dtype=int)
        final = separation(partial + self.information[last], self.blocks, *self.beta).min(axis=-1)
        return [(chosen, float(score)) for chosen, score in zip(members, final)]


def _flat(groups: list[list[int]]) -> list[int]:
    return [o for members in groups for o in members]
