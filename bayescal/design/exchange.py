"""Fedorov's exchange of a plan's configurations among feasible candidates (step 2 of :mod:`bayescal.design.optimise`).

:class:`Exchange` is a part of :class:`~bayescal.design.optimise.PlanDesigner`, not used alone: its
methods read the designer's ``space`` and score information matrices by its ``_score``, ``_scores``
and ``_separated``.  A plan here is a list of groups, each a q2 grid index and the candidate indices
measured at it.
"""

from __future__ import annotations

import math

import numpy as np

from bayescal.errors import InputError

__all__ = ["MAX_PASSES", "Exchange"]

MAX_PASSES = 20
"""Exchange passes at most; on the KR-270 a start settles in 3 to 6."""


class Exchange:
    """The random start and the coordinate exchange of :class:`~bayescal.design.optimise.PlanDesigner`."""

    def _start(self, grid, usable, available, angles, per_angle, rng):
        for _ in range(1000):
            chosen = rng.choice(np.flatnonzero(usable), size=angles, replace=False)
            if self._separated(list(grid[chosen])):
                return [(int(g), list(rng.choice(available[g], size=per_angle, replace=False))) for g in chosen]
        raise InputError(f"no {angles} q2 angles {math.degrees(self.space.min_separation):.0f} deg apart have feasible configurations", source="angles")

    def _exchange(self, groups, grid, usable, available, information, criterion):
        def total(groups):
            return sum(information[c] for _, members in groups for c in members)

        current = self._score(total(groups), criterion)
        # A group's fills depend only on the other groups: unchanged since the last pass, they are not computed again.
        filled: dict[tuple, list] = {}
        for _ in range(MAX_PASSES):
            improved = False
            for g in range(len(groups)):
                # one configuration for another at the same q2
                for slot in range(len(groups[g][1])):
                    angle, members = groups[g]
                    pool = _without(available[angle], members)
                    if not pool.size:
                        continue
                    base = total(groups) - information[members[slot]]
                    scores = self._scores(base + information[pool], criterion)
                    best = int(np.argmin(scores))
                    if scores[best] < current - 1e-12 * abs(current):
                        members[slot], current, improved = int(pool[best]), float(scores[best]), True
                # the whole group to another q2, filled greedily: every angle's fill at once, then taken in turn
                others = [grid[a] for h, (a, _) in enumerate(groups) if h != g]
                angles = [int(a) for a in np.flatnonzero(usable) if self._separated(others + [grid[a]])]
                rest = total(groups[:g] + groups[g + 1 :])
                key = (tuple(angles), len(groups[g][1]), rest.tobytes())
                if key not in filled:
                    filled[key] = self._greedy_fills(angles, len(groups[g][1]), rest, available, information, criterion)
                fills = filled[key]
                for angle, (members, score) in zip(angles, fills):
                    if angle == groups[g][0]:
                        continue
                    if score < current - 1e-12 * abs(current):
                        groups[g], current, improved = (angle, list(members)), score, True
            if not improved:
                break
        return groups

    def _greedy_fills(self, angles: list[int], size: int, rest: np.ndarray, available, information: np.ndarray, criterion: str):
        """For each q2 grid index of ``angles``, ``size`` of its candidates added one by one to the plan of information
        ``rest``, each the best; the members and the criterion of each filled plan.  The angles are scored together."""
        members: list[list[int]] = [[] for _ in angles]
        partial = np.repeat(rest[np.newaxis], len(angles), axis=0)
        for _ in range(size):
            pools = [_without(available[a], chosen) for a, chosen in zip(angles, members)]
            label = np.repeat(np.arange(len(angles)), [len(pool) for pool in pools])
            flat = np.concatenate(pools)
            scores = self._scores(partial[label] + information[flat], criterion, groups=label)
            starts = np.concatenate([[0], np.cumsum([len(pool) for pool in pools])])
            for k, pool in enumerate(pools):
                choice = int(pool[np.argmin(scores[starts[k] : starts[k + 1]])])
                members[k].append(choice)
                partial[k] = partial[k] + information[choice]
        return list(zip(members, self._scores(partial, criterion, groups=np.arange(len(angles)))))


def _without(candidates: np.ndarray, chosen: list[int]) -> np.ndarray:
    """The sorted ``candidates`` (candidate indices) not in ``chosen``: ``np.setdiff1d``'s result, without its sort
    (a pool is a few tens of indices, and a search asks for thousands: 6,582 in ``bayescal plan --model linear``)."""
    return candidates[[c not in chosen for c in candidates.tolist()]] if chosen else candidates
