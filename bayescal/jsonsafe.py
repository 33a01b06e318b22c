"""JSON has no NaN or infinity: every machine-readable result goes through :func:`json_safe`."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["json_safe"]


def json_safe(value):
    """``value`` with every non-finite float, in any nesting of dicts, lists and tuples, as ``None`` (JSON null).

    Finite floats, NumPy's included, become Python floats, NumPy's other scalars their Python
    values; other values pass unchanged.
    """
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(item) for item in value]
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, np.generic):
        # NumPy's integers and booleans: JSON takes their Python values.
        return value.item()
    return value
