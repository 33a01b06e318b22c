"""One way to show a number to a person: rounded to its uncertainty, in the unit the person thinks in.

A posterior mean is shown to the decimal of the second significant digit of its
uncertainty (the sd, or the ±3σ half-width when that is what the row shows), so
``1.23456 ± 0.04321`` reads ``1.235 ± 0.043``. Lengths are shown in μm when they
are errors left after compensation (tens of μm) and in mm when they are
deflections (tenths of a mm); parameters keep the paper's units. These
functions build text only: JSON fields stay numeric.  :func:`table_texts`
applies the same rule to the columns of a table.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from bayescal.units import MM, UM

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["decimals_for", "decimals_of", "rounded_pair", "with_uncertainty", "error_um", "deflection_mm", "table_texts", "fixed"]

SIGNIFICANT = 2
"""Significant digits kept of an uncertainty."""


def decimals_for(uncertainty: float, significant: int = SIGNIFICANT) -> int:
    """Decimals that keep ``significant`` digits of ``uncertainty`` (never negative).

    Parameters
    ----------
    uncertainty : float
        An sd or a half-width, any unit; zero, negative or not finite gives 0 decimals.
    significant : int
        Significant digits kept of the uncertainty.
    """
    if not math.isfinite(uncertainty) or uncertainty <= 0:
        return 0
    return max(0, significant - 1 - math.floor(math.log10(uncertainty)))


def decimals_of(uncertainty: float, significant: int = SIGNIFICANT) -> int:
    """Decimals of a row shown beside ``uncertainty``: those of the uncertainty once rounded (0.0996 -> 0.10: 2)."""
    return decimals_for(_rounded(uncertainty, significant), significant) if math.isfinite(uncertainty) else 0


def rounded_pair(mean: float, uncertainty: float, *, significant: int = SIGNIFICANT) -> tuple[str, str]:
    """``(mean, uncertainty)`` as texts for two table columns, rounded as :func:`with_uncertainty` does; "–" when missing."""
    if not math.isfinite(mean):
        return "–", "–"
    if not math.isfinite(uncertainty):
        return f"{mean:.4g}", "–"
    places = decimals_of(uncertainty, significant)
    return f"{mean:.{places}f}", f"{_rounded(uncertainty, significant):.{places}f}"


def with_uncertainty(mean: float, uncertainty: float, unit: str = "", *, significant: int = SIGNIFICANT) -> str:
    """``mean ± uncertainty unit``, the mean rounded to the uncertainty's last kept decimal.

    Parameters
    ----------
    mean, uncertainty : float
        In the same unit (the one named by ``unit``); ``uncertainty`` is printed as given (sd or 3 sd).
    unit : str
        Appended after a space when not empty.
    significant : int
        Significant digits kept of the uncertainty.
    """
    mean_text, uncertainty_text = rounded_pair(mean, uncertainty, significant=significant)
    if mean_text == "–":
        return mean_text
    text = mean_text if uncertainty_text == "–" else f"{mean_text} ± {uncertainty_text}"
    return text + (f" {unit}" if unit else "")


def error_um(value_mm: float, uncertainty_mm: float | None = None) -> str:
    """An error left after compensation, given in mm, shown in μm (to 0.1 μm or to its uncertainty)."""
    value = value_mm * MM / UM
    if uncertainty_mm is None:
        return f"{value:.1f} μm"
    return with_uncertainty(value, uncertainty_mm * MM / UM, "μm")


def error_length(value_mm: float) -> str:
    """An error left after compensation, given in mm: in μm (to 0.1 μm) below 1 mm, in mm (to 1 μm) from 1 mm."""
    return error_um(value_mm) if abs(value_mm) < 1.0 else f"{value_mm:.3f} mm"


def deflection_mm(value_mm: float, uncertainty_mm: float | None = None) -> str:
    """A deflection, given in mm, shown in mm (to 1 μm or to its uncertainty)."""
    if uncertainty_mm is None:
        return f"{value_mm:.3f} mm"
    return with_uncertainty(value_mm, uncertainty_mm, "mm")


def fixed(decimals: int) -> Callable[[float], str]:
    """A formatter to a fixed number of decimals ("–" when missing), for values without an uncertainty of their own."""
    # + 0.0 turns a rounded -0.0 into 0.0: "-0.0" reads as a sign the value does not have.
    return lambda value: f"{round(value, decimals) + 0.0:.{decimals}f}" if _number(value) and math.isfinite(value) else "–"


def table_texts(
    frame: pd.DataFrame, rounded_to: Mapping[str, str], formats: Mapping[str, Callable[[float], str]] | None = None
) -> pd.DataFrame:
    """The texts a table shows: each value rounded to the uncertainty of its row.

    Parameters
    ----------
    frame : pandas.DataFrame
        The numbers, in the units of their columns.
    rounded_to : mapping
        Column → the column of the same row holding its uncertainty (an sd or a ±3σ
        half-width, in the same unit); an uncertainty column maps to itself and keeps
        :data:`SIGNIFICANT` digits.
    formats : mapping, optional
        Column → a formatter for columns without an uncertainty (:func:`fixed`).

    Returns
    -------
    pandas.DataFrame
        Same index and columns; the named columns as text, the others unchanged.
    """
    texts = frame.astype(object).copy()
    for column, uncertainty in rounded_to.items():
        texts[column] = [
            rounded_pair(float(value), float(spread))[1 if column == uncertainty else 0] if _number(value) else value
            for value, spread in zip(frame[column], frame[uncertainty])
        ]
    for column, formatter in (formats or {}).items():
        texts[column] = [formatter(value) if _number(value) else value for value in frame[column]]
    return texts


def _number(value) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _rounded(value: float, significant: int) -> float:
    """``value`` rounded to ``significant`` significant digits."""
    return round(value, decimals_for(value, significant)) if value > 0 else value
