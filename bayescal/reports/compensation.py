"""The review's section on a compensated machining program: its error along the rows before and after, the worst poses.

It renders the CSV ``bayescal compensate`` writes; every number on it was
computed there.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from bayescal.compensation.results import FLAG_OK, SUMMARY_COLUMNS as COLUMNS, WORST
from bayescal.errors import InputError
from bayescal.reports.page import Page
from bayescal.tables import read_table

__all__ = ["read_compensated", "compensation_section", "plot_program_errors"]


def read_compensated(path: str) -> pd.DataFrame:
    """The compensated program written by ``bayescal compensate``, indexed by line.

    Raises
    ------
    InputError
        When a column of :data:`COLUMNS` or ``flag`` is missing or holds something else.
    """
    frame = read_table(path, dict.fromkeys(COLUMNS, "number") | {"flag": "text"}, units=dict.fromkeys(COLUMNS, "mm"))
    if (frame[list(COLUMNS)] < 0).to_numpy().any():
        raise InputError("negative lengths in the error columns: is it the file `bayescal compensate -o` writes?", source=path)
    return frame


def plot_program_errors(line: np.ndarray, deflection_mm: np.ndarray, rms_mm: np.ndarray, q9973_mm: np.ndarray) -> Figure:
    """The tool's error along the program's rows: without compensation, and left after it (rms and 99.73 %).

    Parameters
    ----------
    line
        ``(P,)`` the rows' lines in the program file.
    deflection_mm, rms_mm, q9973_mm
        ``(P,)`` the columns of the compensated program, mm.
    """
    figure = Figure(figsize=(7.2, 3.8), layout="constrained")
    ax = figure.add_subplot()
    ax.plot(line, deflection_mm, ".", ms=3, color="C1", label="without compensation (deflection)")
    ax.plot(line, q9973_mm, ".", ms=3, color="C3", label="left after it, 99.73 % bound")
    ax.plot(line, rms_mm, ".", ms=3, color="C0", label="left after it, rms")
    ax.set_yscale("log")
    ax.set_xlabel("program line")
    ax.set_ylabel("tool position error [mm]")
    ax.set_title("Compliance error along the program, before and after compensation", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return figure


def compensation_section(page: Page, frame: pd.DataFrame, source: str) -> None:
    """Add the section: the program's totals, the figure and the :data:`WORST` poses by their 99.73 % error."""
    page.heading("compensation", "Compensated machining program")
    if source:
        page.paragraph(f"From {source}.")
    flagged = frame["flag"] != FLAG_OK
    totals = pd.DataFrame(
        {"median": frame[list(COLUMNS)].median(), "max": frame[list(COLUMNS)].max()},
    )
    totals.index.name = "over the program [mm]"
    page.paragraph(f"{len(frame)} poses, {int(flagged.sum())} flagged.", css="verdict" if not flagged.any() else "warning")
    page.table("totals", totals)
    page.figure(
        "program_errors",
        plot_program_errors(frame.index.to_numpy(), *(frame[name].to_numpy() for name in COLUMNS)),
        "The tool's error at each row: its deflection under the process wrench without compensation, "
        "and what the calibration's uncertainty leaves after it.",
    )
    worst = frame.sort_values("error_q9973_mm", ascending=False).head(WORST)[[*COLUMNS, "flag"]]
    worst.index = pd.Index([str(i) for i in worst.index], name="line")
    page.table("worst_poses", worst)
    page.close()
