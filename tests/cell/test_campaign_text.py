"""Tests of bayescal.cell.campaign_text: the campaign rows' text built by NumPy, the same as Python's formatting."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.campaign_text import LARGEST_SCALED, PAD, block_text, csv_line, fixed_digits


def _texts(values: np.ndarray, places: int) -> list[str]:
    return [bytes(row[row != PAD]).decode() for row in fixed_digits(values, places)]


def _python(values: np.ndarray, places: int) -> list[str]:
    """``%.{places}f`` of each value, a value printed as ``-0.0…`` written ``0.0…`` (the writer's rule)."""
    texts = [f"%.{places}f" % v for v in values.tolist()]
    return [t[1:] if t.startswith("-") and not t.strip("-0.") else t for t in texts]


@pytest.mark.parametrize("places", [0, 1, 4, 5, 6])
def test_the_digits_are_those_python_rounds_to(places):
    rng = np.random.default_rng(places)
    whole = rng.integers(-10**9, 10**9, size=20_000)
    halfway = (whole + 0.5) / 10.0**places
    values = np.concatenate([
        rng.normal(size=20_000) * 10.0 ** rng.uniform(-9, 8, size=20_000),
        # half-way decimals and the doubles either side of them: most are not ties in binary, some are
        halfway, np.nextafter(halfway, np.inf), np.nextafter(halfway, -np.inf),
        rng.integers(-2**20, 2**20, size=20_000) / 64.0,  # exact binary ties of the last place
        [0.0, -0.0, 1e-300, -1e-300, 2.675, -2.675, -4e-6, -5e-6, -6e-6, 0.5, 1.5, 2.5, -0.5, 9.999995, 99_999.999995],
        rng.uniform(-1, 1, size=20_000) * 0.999 * LARGEST_SCALED / 10.0**places,
    ])
    values = values[np.abs(values) * 10.0**places < LARGEST_SCALED]
    assert _texts(values, places) == _python(values, places)


def test_values_it_cannot_write_from_an_integer_are_refused():
    assert fixed_digits(np.array([1.0, np.nan]), 5) is None
    assert fixed_digits(np.array([-np.inf]), 5) is None
    assert fixed_digits(np.array([LARGEST_SCALED / 1e5]), 5) is None


def test_a_block_is_the_rows_python_writes():
    # runs of equal values (formatted once a run), a column it formats a value at a time (NaN, beyond the
    # integer's range), integers, texts that need quoting or are not ASCII, and values without decimals
    rng = np.random.default_rng(1)
    runs = np.repeat(rng.normal(size=4) * 100, 3)
    odd = np.array([1.5, np.nan, -0.0, 7.5e15, -2e-6, 3.0, np.inf, 0.1, -1.25, 2.0, 5.0, -7.0])
    markers = np.array(["M1", "M,2", 'M"3', "Mé"] * 3)
    times = np.array([0.1, 0.0, 0.0, 2.5, np.nan, 1e20] * 2)
    columns = [(np.arange(12) // 3 + 1, None), (runs, 6), (odd, 5), (markers, None), (rng.normal(size=12), 5), (times, None)]
    expected = "".join(
        csv_line([c, _python(np.array([r]), 6)[0], _python(np.array([o]), 5)[0], m, _python(np.array([p]), 5)[0], t])
        for c, r, o, m, p, t in zip(*(values.tolist() for values, _ in columns))
    )
    assert block_text(columns) == expected
