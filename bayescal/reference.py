"""The values Klimchik et al. publish, to set every result beside them.

``data/paper_reference.csv`` holds Table II (compensator geometry) and Table IV
(elastostatic parameters of the KR-270) with their ±3σ half-widths; this module
is the one place that reads it, and the one place that sets an estimate beside
it: :func:`width_3sd_pct` is the paper's relative interval width and
:func:`beside_published` the comparison every report and the CLI print.
"""

from __future__ import annotations

from functools import cache
from types import MappingProxyType
from os import PathLike
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from bayescal.errors import InputError
from bayescal.tables import read_columns, read_table

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["REFERENCE_FILE", "read_paper_reference", "published_in", "published", "published_width_pct", "width_3sd_pct", "beside_published"]

REFERENCE_FILE = Path(__file__).resolve().parents[1] / "data" / "paper_reference.csv"
"""The repository's copy of the published values."""

REFERENCE_COLUMNS = {"table": "text", "parameter": "text", "unit": "text", "value": "number", "ci3": "number"}
"""The reference file's columns and their kinds."""


def read_paper_reference(path: str | PathLike[str] = REFERENCE_FILE) -> pd.DataFrame:
    """Read published values and ±3σ half-widths.

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, with columns ``table, unit, value, ci3``
        (``ci3`` the half-width of the published ±3σ interval, in ``unit``).
    """
    frame = read_table(path, REFERENCE_COLUMNS)
    _check_listed_once(frame.index.tolist(), frame["parameter"].tolist(), path)
    return frame.set_index("parameter")


def published_in(path: str | PathLike[str], table: str) -> dict[str, tuple[float, float]]:
    """``{parameter: (value, ±3σ half-width)}`` of Table ``table`` in the reference file ``path``, in its rows' order
    (empty when it has none): :func:`read_paper_reference`'s rows of that table, read without pandas."""
    lines, columns = read_columns(path, REFERENCE_COLUMNS)
    _check_listed_once(lines, columns["parameter"], path)
    rows = zip(columns["table"], columns["parameter"], columns["value"], columns["ci3"])
    return {str(name): (float(value), float(half)) for listed, name, value, half in rows if listed == table}


def _check_listed_once(lines: list[int], names: list[str], path: str | PathLike[str]) -> None:
    """Refuse a parameter listed twice, naming the line of its second listing."""
    seen: set[str] = set()
    for line, name in zip(lines, names):
        if name in seen:
            raise InputError("parameter listed twice", source=str(path), line=int(line), column="parameter")
        seen.add(name)


@cache
def published(table: str) -> MappingProxyType[str, tuple[float, float]]:
    """``{parameter: (value, ±3σ half-width)}`` of the paper's Table ``"II"`` or ``"IV"``, in the file's units."""
    rows = published_in(REFERENCE_FILE, table)
    if not rows:
        raise ValueError(f"no Table {table} in {REFERENCE_FILE.name}")
    # Read-only, since the cache hands every caller the same mapping.
    return MappingProxyType(rows)


def width_3sd_pct(mean, sd):
    """The relative width of the paper's intervals: 3 sd in % of ``|mean|`` (infinite for a zero mean).

    Works elementwise on floats, arrays and pandas objects of matching shape.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return 300.0 * sd / np.abs(mean)


def published_width_pct(table: str, name: str) -> float:
    """Table ``table``'s ±3σ half-width of ``name`` in % of its value; NaN when the table does not list it."""
    value, half_width = published(table).get(name, (np.nan, np.nan))
    return 100.0 * half_width / value


def beside_published(estimates: pd.DataFrame, table: str, reference: pd.DataFrame | None = None) -> pd.DataFrame:
    """Estimates with ±3σ intervals set beside the paper's Table ``table``.

    Parameters
    ----------
    estimates
        Indexed by parameter, columns ``mean`` and ``sd`` in the paper's units
        (NaN for a parameter without an estimate).
    table
        ``"II"`` or ``"IV"``.
    reference
        Published values as :func:`read_paper_reference` returns them; default the repository's copy.

    Returns
    -------
    pandas.DataFrame
        Indexed as ``estimates``, columns ``mean``, ``half_width_3sd`` (3 sd),
        ``width_3sd_pct``, ``published``, ``published_half_width_3sd``,
        ``published_width_pct``, ``difference`` (mean − published, in the
        parameter's unit), ``difference_in_sd`` (in our sd),
        ``difference_in_published_sd`` (in the paper's σ, a third of its
        half-width) and ``published_inside_3sd`` (bool); the published
        columns are NaN for a parameter the table does not list.
    """
    import pandas as pd

    if reference is None:
        rows = published(table)
        value = pd.Series({name: rows[name][0] for name in estimates.index if name in rows}, dtype=float)
        half = pd.Series({name: rows[name][1] for name in estimates.index if name in rows}, dtype=float)
    else:
        listed = reference[reference["table"] == table]
        value, half = listed["value"].astype(float), listed["ci3"].astype(float)
    value = value.reindex(estimates.index)
    half = half.reindex(estimates.index)
    mean, sd = estimates["mean"].astype(float), estimates["sd"].astype(float)
    difference = mean - value
    frame = pd.DataFrame(
        {
            "mean": mean,
            "half_width_3sd": 3 * sd,
            "width_3sd_pct": width_3sd_pct(mean, sd),
            "published": value,
            "published_half_width_3sd": half,
            "published_width_pct": 100.0 * half / value,
            "difference": difference,
            "difference_in_sd": difference / sd,
            "difference_in_published_sd": difference / (half / 3),
            "published_inside_3sd": np.abs(difference) <= 3 * sd,
        },
        index=estimates.index,
    )
    frame.index.name = "parameter"
    return frame
