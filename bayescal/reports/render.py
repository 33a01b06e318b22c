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
from collections.abc import Mapping

from matplotlib.figure import Figure

from bayescal.forked import available_cores, forked_map

__all__ = ["png_files", "FIGURE_DPI"]

FIGURE_DPI = 110
"""Resolution of the PNG figures: a 6.4-inch figure is 700 pixels wide, sharp on a 1280-pixel page."""


def png(figure: Figure) -> bytes:
    """The PNG file of ``figure`` at :data:`FIGURE_DPI`."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=FIGURE_DPI)
    return buffer.getvalue()


def png_files(figures: Mapping[str, Figure]) -> dict[str, bytes]:
    """``{name: PNG bytes}`` of ``figures``, in their order, drawn by :func:`~bayescal.forked.forked_map`'s processes."""
    names, drawn = list(figures), list(figures.values())
    return dict(zip(names, forked_map(lambda index: png(drawn[index]), len(drawn), available_cores())))
