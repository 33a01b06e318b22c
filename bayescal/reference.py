"""The values Klimchik et al. publish, to set every result beside them.

``data/paper_reference.csv`` holds Table II (compensator geometry) and Table IV
(elastostatic parameters of the KR-270) with their ±3σ half-widths; this module
is the one place that reads it.
"""

from __future__ import annotations

from functools import cache
from types import MappingProxyType
from os import PathLike
from pathlib import Path

import pandas as pd

from bayescal.errors import InputError
from bayescal.tables import read_table

__all__ = ["REFERENCE_FILE", "read_paper_reference", "published"]

REFERENCE_FILE = Path(__file__).resolve().parents[1] / "data" / "paper_reference.csv"
"""The repository's copy of the published values."""


def read_paper_reference(path: str | PathLike[str] = REFERENCE_FILE) -> pd.DataFrame:
    """Read published values and ±3σ half-widths.

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, with columns ``table, unit, value, ci3``
        (``ci3`` the half-width of the published ±3σ interval, in ``unit``).
    """
    frame = read_table(path, {"table": "text", "parameter": "text", "unit": "text", "value": "number", "ci3": "number"})
    duplicated = frame["parameter"].duplicated()
    if duplicated.any():
        line = int(frame.index[duplicated.to_numpy()][0])
        raise InputError("parameter listed twice", source=str(path), line=line, column="parameter")
    return frame.set_index("parameter")


@cache
def published(table: str) -> MappingProxyType[str, tuple[float, float]]:
    """``{parameter: (value, ±3σ half-width)}`` of the paper's Table ``"II"`` or ``"IV"``, in the file's units."""
    reference = read_paper_reference()
    rows = reference[reference["table"] == table]
    if rows.empty:
        raise ValueError(f"no Table {table} in {REFERENCE_FILE.name}")
    # Read-only, since the cache hands every caller the same mapping.
    return MappingProxyType({str(name): (float(row["value"]), float(row["ci3"])) for name, row in rows.iterrows()})
