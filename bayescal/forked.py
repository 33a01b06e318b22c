"""Independent pieces of work shared out among worker processes forked from this one.

A forked worker holds everything its parent held when it was forked (a figure drawn, a plan search's candidates and
robot model), so nothing of it is pickled: only the index of a piece goes to the worker and its result comes back.
The work is the same in a forked process as in its parent, bit for bit.  Where processes are not forked (other
systems than Linux, a process running other threads, a BLAS pool's among them) or one worker is asked for, the
pieces run one after another in this process.
"""

from __future__ import annotations

import multiprocessing
import os
import sys
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import TypeVar

__all__ = ["available_cores", "forked_map"]

T = TypeVar("T")

_FORKED: list[Callable[[int], object]] = []
"""The work a forked worker does, set in the parent just before its workers are forked and cleared after."""


def available_cores() -> int:
    """The cores this process may run on (its affinity, as ``taskset`` or a batch system sets it)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _single_threaded() -> bool:
    """Whether this process runs one thread as the system counts them, BLAS's and other libraries' included: a fork
    copies the calling thread alone, and a lock another thread held stays held in the child (a notebook's kernel, a
    BLAS pool of several threads; the command line runs BLAS on one)."""
    try:
        return len(os.listdir("/proc/self/task")) == 1
    except OSError:
        return threading.active_count() == 1


def _workers(count: int, workers: int) -> int:
    """Worker processes for ``count`` pieces, at most ``workers``: 1 where this process cannot fork, or should not
    (:func:`_single_threaded`)."""
    if count < 2 or workers < 2 or not sys.platform.startswith("linux") or "fork" not in multiprocessing.get_all_start_methods():
        return 1
    return min(count, workers) if _single_threaded() else 1


def _run(index: int) -> object:
    return _FORKED[0](index)


def forked_map(work: Callable[[int], T], count: int, workers: int) -> Iterator[T]:
    """``work(0), ..., work(count - 1)`` in this order, computed by at most ``workers`` processes forked from this one.

    ``work`` is never pickled (a closure will do); its results are.  The results are yielded as they come, in order,
    so that a caller can report progress; the workers end when the iterator is exhausted or closed.
    """
    processes = _workers(count, workers)
    if processes == 1:
        yield from (work(index) for index in range(count))
        return
    _FORKED[:] = [work]
    try:
        with ProcessPoolExecutor(processes, mp_context=multiprocessing.get_context("fork")) as pool:
            yield from pool.map(_run, range(count))
    finally:
        _FORKED.clear()
