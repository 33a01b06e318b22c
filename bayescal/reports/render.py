"""Figures drawn to PNG, on as many cores as there are figures and cores to draw them.

Drawing and saving the review's nine figures is half of ``bayescal report``'s time (1.8 of 3.6 s on the 2-core
development machine); each figure is drawn on its own, so the figures are shared out among worker processes forked
from this one, which hold them already (no figure is pickled, only each PNG's bytes come back).  Agg draws the same
pixels in a forked process as in its parent: the files are byte for byte those of one process.  Where processes are
not forked (other systems than Linux, a process running other threads) or there is one core, the figures are drawn
one after another.
"""

from __future__ import annotations

import io
import multiprocessing
import os
import sys
import threading
from collections.abc import Mapping
from concurrent.futures import ProcessPoolExecutor

from matplotlib.figure import Figure

__all__ = ["png_files", "FIGURE_DPI"]

FIGURE_DPI = 110
"""Resolution of the PNG figures: a 6.4-inch figure is 700 pixels wide, sharp on a 1280-pixel page."""

_FORKED: list[Figure] = []
"""The figures a forked worker draws, set in the parent just before its workers are forked."""


def png(figure: Figure) -> bytes:
    """The PNG file of ``figure`` at :data:`FIGURE_DPI`."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=FIGURE_DPI)
    return buffer.getvalue()


def _png_of(index: int) -> bytes:
    return png(_FORKED[index])


def _workers(count: int) -> int:
    """Worker processes for ``count`` figures: the cores this process may run on; 1 where it cannot fork, or should
    not: a process running other threads (a notebook's kernel) may fork a child holding one of their locks."""
    if count < 2 or not sys.platform.startswith("linux") or "fork" not in multiprocessing.get_all_start_methods():
        return 1
    if threading.active_count() > 1:
        return 1
    return min(count, len(os.sched_getaffinity(0)))


def png_files(figures: Mapping[str, Figure]) -> dict[str, bytes]:
    """``{name: PNG bytes}`` of ``figures``, in their order, drawn by :func:`_workers` processes."""
    names, drawn = list(figures), list(figures.values())
    workers = _workers(len(drawn))
    if workers == 1:
        return {name: png(figure) for name, figure in zip(names, drawn)}
    _FORKED[:] = drawn
    try:
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
            return dict(zip(names, pool.map(_png_of, range(len(drawn)))))
    finally:
        _FORKED.clear()
