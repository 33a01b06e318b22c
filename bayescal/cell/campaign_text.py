"""The text of a campaign file's rows, built as bytes by NumPy: :func:`~bayescal.cell.campaign.write_campaign`'s writer.

Python's ``%`` formatting of a campaign of 100,000 configurations (900,000 rows, 5.4 million positions) took most
of the writer's time.  Here each field of a block of rows is a row of bytes of one width, padded with 0xFF (a
byte no UTF-8 text holds), the fields and their separators side by side; dropping the padding leaves the
block's text.  A column of fixed decimals is written from the correctly rounded integer of ``value × 10^places``
(:func:`fixed_digits`): the decimal ``%.{places}f`` gives of the binary value, a value that rounds to zero
without its sign.  A column of runs of equal values (a configuration's joints and wrench, equal on its rows) is
formatted once a run, a column of integers or texts once a distinct value; a column of fixed decimals that
:func:`fixed_digits` refuses (a value not finite or too large) and any other column (the reading times) are
formatted by Python a value at a time, as before.
"""

from __future__ import annotations

import csv
import io

import numpy as np

__all__ = ["block_text", "csv_line", "fixed_digits"]

PAD = 0xFF
"""The padding byte of the fields' rows, dropped from the text: never a byte of UTF-8."""

_SPLIT = 134217729.0
"""2^27 + 1, Veltkamp's constant: it splits a double into two halves of 26 bits, whose products are exact."""

LARGEST_SCALED = 2.0**50
"""Largest ``|value| × 10^places`` written from its integer: below 2^52 the half-units the rounding compares are exact."""


def csv_line(fields: list) -> str:
    """``fields`` as one line of :mod:`csv` (quoted where they need it), ending in a newline."""
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow(fields)
    return out.getvalue()


def _product_error(a: np.ndarray, b: float, product: np.ndarray) -> np.ndarray:
    """``a × b − product`` exactly, for ``product = fl(a × b)`` (Dekker's two-product: the halves' products are exact)."""
    spread = _SPLIT * a
    a_high = spread - (spread - a)
    a_low = a - a_high
    spread_b = _SPLIT * b
    b_high = spread_b - (spread_b - b)
    b_low = b - b_high
    return ((a_high * b_high - product) + a_high * b_low + a_low * b_high) + a_low * b_low


def fixed_digits(values: np.ndarray, places: int) -> np.ndarray | None:
    """``(N, width)`` uint8: ``"%.{places}f" % value`` of each value ``(N,)``, right-aligned and padded with :data:`PAD`,
    a value that rounds to zero written without its sign (``0.000``, never ``-0.000``); None when a value is not
    finite or ``|value| × 10^places`` reaches :data:`LARGEST_SCALED`.

    The digits are those of the integer nearest to the exact product ``value × 10^places``, half-way cases to the even
    one, as Python rounds a float to fixed decimals: the product rounded to a double, ``p``, and its exact error ``e``
    (:func:`_product_error`) decide it.  ``p − rint(p)`` is exact and a multiple of ``p``'s last place, so where it is
    not ±1/2, the error, at most half that place, cannot carry the product past a half-way point; where it is ±1/2,
    the error's sign says on which side the exact product lies, and an error of zero is a true half-way case, which
    ``rint`` has already sent to the even integer.
    """
    values = np.asarray(values, dtype=float)
    scale = 10.0**places
    if not np.all(np.isfinite(values)) or (values.size and np.max(np.abs(values)) * scale >= LARGEST_SCALED):
        return None
    product = values * scale
    nearest = np.rint(product)
    half = product - nearest
    # the error is needed at the half-way points of the rounded product alone
    ties = np.flatnonzero(np.abs(half) == 0.5)
    beyond = np.sign(_product_error(values[ties], scale, product[ties])) == np.sign(half[ties])
    nearest[ties[beyond]] += np.sign(half[ties[beyond]])
    integer = nearest.astype(np.int64)
    magnitude = np.abs(integer)
    width = max(places + 1, len(str(int(magnitude.max(initial=0)))))
    whole = width - places
    figures = _figures(magnitude, width)
    # the whole part's leading zeros are padding, all but its units
    powers = 10 ** np.arange(width - 1, width - whole, -1, dtype=np.int64)
    figures[:, : whole - 1][magnitude[:, np.newaxis] < powers] = PAD
    text = np.full((len(values), width + 2), PAD, dtype=np.uint8)
    text[:, 0] = np.where(integer < 0, ord("-"), PAD)
    text[:, 1 : whole + 1] = figures[:, :whole]
    if places:
        text[:, whole + 1] = ord(".")
    text[:, whole + 2 :] = figures[:, whole:]
    return text


_GROUPS = np.frombuffer(b"".join(b"%04d" % group for group in range(10_000)), dtype=np.uint32)
"""The four ASCII digits of each number below 10,000, one 32-bit word each (its bytes in the text's order)."""


def _figures(magnitude: np.ndarray, width: int) -> np.ndarray:
    """``(N, width)`` uint8 ASCII: the last ``width`` decimal digits of whole numbers ``(N,)``, leading zeros written.

    Four digits at a time from :data:`_GROUPS`: a division by a constant a group instead of one a digit."""
    groups = -(-width // 4)
    words = np.empty((len(magnitude), groups), dtype=np.uint32)
    rest = magnitude
    for group in range(groups - 1, -1, -1):
        rest, words[:, group] = np.divmod(rest, 10_000)
    words = _GROUPS[words]
    return words.view(np.uint8).reshape(len(magnitude), 4 * groups)[:, 4 * groups - width :].copy()


def _texts_bytes(texts: list[str], rows: np.ndarray | None = None) -> np.ndarray:
    """``(N, width)`` uint8 of the UTF-8 ``texts``, left-aligned and padded with :data:`PAD`, taken at ``rows`` when given."""
    encoded = [text.encode("utf-8") for text in texts]
    lengths = np.array([len(text) for text in encoded], dtype=np.int64)
    table = np.full((len(encoded), max(int(lengths.max(initial=0)), 1)), PAD, dtype=np.uint8)
    table[np.arange(table.shape[1]) < lengths[:, np.newaxis]] = np.frombuffer(b"".join(encoded), dtype=np.uint8)
    return table if rows is None else table[rows]


def _rounded_texts(values: np.ndarray, places: int) -> list[str]:
    """``"%.{places}f"`` of each value, one at a time, a value that prints as ``-0.000…`` written ``0.000…``."""
    spec = f"%.{places}f"
    texts = [spec % v for v in values.tolist()]
    return [text if not text.startswith("-") or text.strip("-0.") else text[1:] for text in texts]


def _fixed_columns(values: np.ndarray, places: int) -> np.ndarray:
    """The fields of neighbouring columns of the same fixed decimals ``(N, k)``, comma-separated ``(N, width)``; rows that
    repeat the row before (a configuration's joints and wrench, equal on its rows) are formatted once."""
    values = values.astype(float)
    change = np.ones(len(values), dtype=bool)
    change[1:] = np.any(values[1:] != values[:-1], axis=1)
    starts = np.flatnonzero(change)
    runs = 2 * len(starts) < len(values)
    distinct = (values[starts] if runs else values).ravel()
    text = fixed_digits(distinct, places)
    if text is None:
        text = _texts_bytes(_rounded_texts(distinct, places))
    fields = text.reshape(-1, values.shape[1], text.shape[1])
    text = np.concatenate([fields, np.full(fields.shape[:2] + (1,), ord(","), dtype=np.uint8)], axis=2).reshape(len(fields), -1)[:, :-1]
    return text[np.repeat(np.arange(len(starts)), np.diff(np.append(starts, len(values))))] if runs else text


def _column(values: np.ndarray) -> np.ndarray:
    """The fields of one column ``(N,)``, ``(N, width)`` uint8, as :mod:`csv` writes a value (an integer as ``%d``)."""
    if values.dtype.kind in "iuUS":
        distinct, rows = np.unique(values, return_inverse=True)
        spec = (lambda v: "%d" % v) if values.dtype.kind in "iu" else (lambda v: csv_line([v])[:-1])
        return _texts_bytes([spec(v) for v in distinct.tolist()], rows.ravel())
    # a value at a time, the texts of equal values shared
    known: dict = {}
    return _texts_bytes([known[v] if v in known else known.setdefault(v, csv_line([v])[:-1]) for v in values.tolist()])


def block_text(columns: list[tuple[np.ndarray, int | None]]) -> str:
    """The CSV lines of rows given as columns ``(values (N,), decimals or None)``: fixed decimals, or as :mod:`csv`
    writes the value (an integer column as ``%d``)."""
    n = len(columns[0][0])
    parts = []
    k = 0
    while k < len(columns):
        places = columns[k][1]
        # neighbouring columns of the same decimals formatted together: a few calls of NumPy a block, not one a column
        group = 1
        while places is not None and k + group < len(columns) and columns[k + group][1] == places:
            group += 1
        part = _column(columns[k][0]) if places is None else _fixed_columns(np.stack([v for v, _ in columns[k : k + group]], axis=1), places)
        parts += [part, np.full((n, 1), ord(","), dtype=np.uint8)]
        k += group
    parts[-1] = np.full((n, 1), ord("\n"), dtype=np.uint8)
    text = np.concatenate(parts, axis=1)
    return text[text != PAD].tobytes().decode("utf-8")
