"""Studies of many simulated campaigns, run on any :class:`concurrent.futures.Executor`.

Every study that repeats a simulation (coverage, plan scoring, detection
power) maps one task over independent random streams.  The streams are
children of one :class:`numpy.random.SeedSequence`, one per task and fixed
before anything runs, so a study's result depends on its seed only, never on
the number of workers or on which worker ran which task.  The default
executor is a process pool on all cores; a user with a cluster passes its
executor instead (for example ``dask.distributed.Client().get_executor()``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from functools import partial
from typing import Any, TypeVar

import numpy as np

__all__ = ["seeded_map"]

T = TypeVar("T")


def seeded_map(
    task: Callable[..., T],
    items: Iterable[Any],
    seed: int | np.random.SeedSequence | Sequence[np.random.SeedSequence],
    *,
    executor: Executor | None = None,
    progress: str | None = None,
    **shared: Any,
) -> list[T]:
    """``[task(item, rng, **shared) for item in items]`` with one independent generator per item.

    Parameters
    ----------
    task
        A module-level function (so that a process pool can send it) taking an
        item, a :class:`numpy.random.Generator` and the ``shared`` keywords.
    items
        What each task works on (a campaign index, a plan, a magnitude...).
    seed
        Root of the random streams: the ``i``-th item gets the ``i``-th child; or one
        :class:`numpy.random.SeedSequence` per item, for a study whose items share
        streams (the same campaigns planted with several magnitudes of an effect).
    executor
        Where the tasks run; None: a process pool on all cores, shut down on return.
    progress
        Label of a progress bar on stderr, counting the tasks done in the order of ``items``, its
        remaining time measured on those done (drawn only on a terminal); None: no bar.
    **shared
        Keyword arguments passed to every task (sent once per task).

    Returns
    -------
    list
        The tasks' results, in the order of ``items``.
    """
    items = list(items)
    if isinstance(seed, Sequence):
        if len(seed) != len(items):
            raise ValueError(f"seed gives {len(seed)} streams for {len(items)} items")
        streams = list(seed)
    else:
        streams = (seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)).spawn(len(items))
    generators = [np.random.default_rng(stream) for stream in streams]
    call = partial(_call, task, shared)
    if executor is not None:
        return _collected(executor.map(call, items, generators), len(items), progress)
    with ProcessPoolExecutor(max_workers=os.cpu_count()) as pool:
        return _collected(pool.map(call, items, generators), len(items), progress)


def _collected(results: Iterable[T], total: int, progress: str | None) -> list[T]:
    from bayescal.design.progress import Progress

    bar = Progress(total, progress or "", progress is not None)
    collected = []
    for result in results:
        collected.append(result)
        bar.step()
    bar.close()
    return collected


def _call(task: Callable[..., T], shared: dict[str, Any], item: Any, rng: np.random.Generator) -> T:
    return task(item, rng, **shared)
