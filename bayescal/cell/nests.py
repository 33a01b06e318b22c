"""The reference-nest file: readings of reflectors fixed in the world, read between configurations.

One row per reading of a fixed nest::

    nest, t_s, x_mm, y_mm, z_mm

* ``nest`` names the reflector's nest (any text); its true position is unknown and
  is estimated with the tracker's drift (:mod:`bayescal.registration.nest_drift`);
* ``t_s`` is the reading's time in seconds on the campaign's clock (the campaign's
  ``t0_s, t1_s`` columns, which a campaign read with nests must then carry);
* ``x_mm, y_mm, z_mm`` the reading, in the frame of the campaign's positions.

Lines starting with ``#`` are provenance notes.  A nest read once says nothing
about the drift (its position is free), so every nest needs two readings at
distinct times.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.errors import InputError
from bayescal.tables import read_header, read_table
from bayescal.units import MM

__all__ = ["Nests", "read_nests", "NEST_COLUMNS", "require_times", "nest_plan_column", "read_nest_column", "NEST_PLAN_COLUMN"]

NEST_COLUMNS = ("nest", "t_s", "x_mm", "y_mm", "z_mm")
NEST_PLAN_COLUMN = "read_nests"
"""A plan's column saying at which configurations (1) the reference nests are read; plan readers ignore it."""


@dataclass(frozen=True, eq=False)
class Nests:
    """Readings of fixed reference nests, in SI units.

    Attributes
    ----------
    name : numpy.ndarray of str, shape (n,)
        The nest each reading is of.
    times : numpy.ndarray, shape (n,)
        Reading times, s (the campaign's clock).
    position : numpy.ndarray, shape (n, 3)
        Readings in the campaign's frame, m.
    lines : numpy.ndarray of int, shape (n,)
        Line numbers in the source file (0 for readings not read from a file).
    source : str
        The file, or a description.
    """

    name: np.ndarray
    times: np.ndarray
    position: np.ndarray
    lines: np.ndarray
    source: str = "<memory>"

    def __len__(self) -> int:
        return len(self.name)

    def moved(self, to_base: Callable[[np.ndarray], np.ndarray]) -> Nests:
        """The readings moved by ``to_base`` ((n, 3) m to (n, 3) m), as a registration moves the campaign."""
        return Nests(self.name, self.times, to_base(self.position), self.lines, self.source)

    def write(self, path: str | PathLike[str], comments: tuple[str, ...] = ()) -> None:
        """Write the file (positions with 5 decimals in mm, times with 1 decimal in s); ``comments`` as ``#`` lines."""
        lines = [f"# {comment}" for comment in comments] + [",".join(NEST_COLUMNS)]
        for name, t, p in zip(self.name, self.times, self.position / MM):
            lines.append(f"{name},{t:.1f}," + ",".join(f"{round(float(v), 5) + 0.0:.5f}" for v in p))
        Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def read_nests(path: str | PathLike[str]) -> Nests:
    """Read and check a reference-nest file (format in the module documentation).

    Raises
    ------
    InputError
        Naming the line and column: a missing column, a value that is not a number,
        a nest read twice at one time, or a nest read fewer than twice at distinct times.
    """
    source = str(path)
    units = {"t_s": "s", "x_mm": "mm", "y_mm": "mm", "z_mm": "mm"}
    frame = read_table(path, {"nest": "text"} | dict.fromkeys(NEST_COLUMNS[1:], "number"), units=units)
    names = frame["nest"].astype(str).str.strip().to_numpy(dtype=str)
    times = frame["t_s"].to_numpy(dtype=float)
    lines = frame.index.to_numpy(dtype=int)
    seen: dict[tuple[str, float], int] = {}
    for line, name, t in zip(lines, names, times):
        if (name, t) in seen:
            raise InputError(
                f"nest '{name}' is already read at t_s = {t:g} on line {seen[name, t]}: one reading per nest and time",
                source=source, line=int(line), column="t_s",
            )
        seen[name, t] = int(line)
    for name in dict.fromkeys(names):
        mine = names == name
        if np.unique(times[mine]).size < 2:
            raise InputError(
                f"nest '{name}' is read at one time only: a nest's position is unknown, so it shows the drift only "
                "when read again later (read every nest at least twice, e.g. every 5-15 min)",
                source=source, line=int(lines[np.flatnonzero(mine)[0]]), column="nest",
            )
    position = frame[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float) * MM
    return Nests(names, times, position, lines, source)


def require_times(campaign_times: np.ndarray | None, campaign_source: str, option: str = "--nests", nests: Nests | None = None) -> None:
    """Refuse nests with a campaign that gives no reading times (its readings cannot be placed on the nests' clock),
    or, given ``nests``, whose times do not overlap the nests' (another clock: the drift would be extrapolated)."""
    if campaign_times is None:
        raise InputError(
            f"{option} needs the campaign's reading times: add the columns t0_s, t1_s (the unloaded and loaded "
            "readings' times in s, on the nests' clock)",
            source=campaign_source,
        )
    if nests is not None and (campaign_times.max() < nests.times.min() or campaign_times.min() > nests.times.max()):
        raise InputError(
            f"the nests are read from {nests.times.min():g} to {nests.times.max():g} s, the campaign from "
            f"{campaign_times.min():g} to {campaign_times.max():g} s: expected both on one clock, the nests read "
            "between the campaign's readings",
            source=nests.source,
        )


def nest_plan_column(n_configurations: int, every: int) -> tuple[str, np.ndarray]:
    """The plan's :data:`NEST_PLAN_COLUMN` ``(n_configurations,)``: 1 at configurations 1, 1 + ``every``, …, else 0;
    and the note that says when to read the nests there."""
    note = (f"{NEST_PLAN_COLUMN} = 1: read every reference nest at this configuration while its load hangs and again after "
            "it is removed, at each repeat; give the readings to calibrate and critique with --nests NESTS.csv")
    return note, (np.arange(n_configurations) % every == 0).astype(int)


def read_nest_column(path: str | PathLike[str]) -> np.ndarray | None:
    """(configurations,) bool: where the plan CSV at ``path`` reads the reference nests; None without the column.

    Raises
    ------
    InputError
        A value of the column other than 0 or 1, naming its line.
    """
    header = read_header(path)
    if header is None or NEST_PLAN_COLUMN not in header[1]:
        return None
    frame = read_table(path, {NEST_PLAN_COLUMN: "integer"})
    values = frame[NEST_PLAN_COLUMN].to_numpy(dtype=int)
    wrong = np.flatnonzero((values != 0) & (values != 1))
    if wrong.size:
        raise InputError(f"expected 1 (read the reference nests at this configuration) or 0, got {values[wrong[0]]}",
                         source=str(path), line=int(frame.index[wrong[0]]), column=NEST_PLAN_COLUMN)
    return values.astype(bool)
