"""Tests of bayescal.cell.plausible: the load rules the cell file and the options share."""

from __future__ import annotations

import math
import shutil

import pytest

from bayescal.cell.config import load_cell
from bayescal.cell.plausible import couple_limit_violation, force_limit_violation, mass_range_violation
from bayescal.cli import main
from bayescal.errors import InputError

CAPACITY_KG = 270.0
G = 9.80665


@pytest.mark.parametrize(
    ("low", "high", "words"),
    [
        (250.0, 280.0, None),
        (2.7, 2.7, None),
        (540.0, 540.0, None),
        (280.0, 250.0, "expected the lighter mass first, got 280 kg then 250 kg"),
        (0.0, 280.0, "expected masses above 0 kg"),
        (-5.0, 280.0, "expected masses above 0 kg"),
        (math.nan, 280.0, "expected finite masses"),
        (250.0, math.inf, "expected finite masses"),
        (25000.0, 28000.0, "more than the 540 kg the arm can plausibly carry (2 x its capacity of 270 kg): is it in g instead of kg?"),
        (1e6, 2e6, "more than the 540 kg"),
        (0.25, 0.28, "below 2.7 kg (1% of the arm's capacity of 270 kg), too light to deflect the arm beyond the tracker's noise: "
                     "is it in tonnes instead of kg?"),
        (0.0001, 0.0002, "too light to deflect"),
    ],
)
def test_the_mass_rule(low, high, words):
    reason = mass_range_violation(low, high, CAPACITY_KG)
    assert reason is None if words is None else words in reason, reason


def test_a_unit_hint_only_where_the_value_in_that_unit_is_plausible():
    assert mass_range_violation(25000.0, 28000.0, CAPACITY_KG).endswith("is it in g instead of kg?")
    assert "?" not in mass_range_violation(1e6, 2e6, CAPACITY_KG)  # 2000 kg as grams: still too heavy
    assert "?" not in mass_range_violation(0.0001, 0.0002, CAPACITY_KG)  # 0.2 kg as tonnes: still too light
    assert "?" not in force_limit_violation(1e-9, CAPACITY_KG, G)


def test_without_a_capacity_only_the_range_is_checked():
    assert mass_range_violation(25000.0, 28000.0) is None
    assert "lighter mass first" in mass_range_violation(28000.0, 25000.0)


@pytest.mark.parametrize(
    ("force", "words"),
    [
        (2750.0, None),
        (27.0, None),
        (1e-9, "below 26 N"),
        (2.75, "is it in kN instead of N?"),
        (0.0, "expected a force above 0 N"),
        (math.nan, "expected a force above 0 N"),
        (6000.0, "more than the 5296 N the arm can plausibly hold"),
        (2.75e6, "is it in mN instead of N?"),
    ],
)
def test_the_force_rule(force, words):
    reason = force_limit_violation(force, CAPACITY_KG, G)
    assert reason is None if words is None else words in reason, reason


@pytest.mark.parametrize(
    ("couple", "words"),
    [(0.0, None), (500.0, None), (5500.0, None), (500000.0, "is it in N·mm instead of N·m?"), (-1.0, "0 N·m or more"), (6000.0, "beyond any tool")],
)
def test_the_couple_rule(couple, words):
    reason = couple_limit_violation(couple, 2750.0, CAPACITY_KG, G)
    assert reason is None if words is None else words in reason, reason


def _cell(data_dir, tmp_path, name, old, new):
    shutil.copytree(data_dir / "robots", tmp_path / "robots", dirs_exist_ok=True)
    text = (data_dir / name).read_text()
    assert old in text
    path = tmp_path / "cell.toml"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize(
    ("name", "old", "new", "key"),
    [
        ("kr270.toml", "mass_kg = [250.0, 280.0]", "mass_kg = [25000.0, 28000.0]", "design.mass_kg"),
        ("kr270.toml", "mass_kg = [250.0, 280.0]", "mass_kg = [280.0, 250.0]", "design.mass_kg"),
        ("kr270.toml", "mass_kg = [250.0, 280.0]", "mass_kg = [0.25, 0.28]", "design.mass_kg"),
        ("kr270.toml", "mass_kg = 265.0", "mass_kg = 265000.0", "load.mass_kg"),
        ("kr270_any_load.toml", "force_max_N = 2750.0", "force_max_N = 1e-9", "load.force_max_N"),
        ("kr270_any_load.toml", "force_max_N = 2750.0", "force_max_N = 2.75", "load.force_max_N"),
        ("kr270_any_load.toml", "couple_max_Nm = 500.0", "couple_max_Nm = 500000.0", "load.couple_max_Nm"),
    ],
)
def test_the_cell_names_its_line_and_key(data_dir, tmp_path, name, old, new, key):
    path = _cell(data_dir, tmp_path, name, old, new)
    line = next(i for i, text in enumerate(path.read_text().splitlines(), start=1) if text.startswith(new))
    with pytest.raises(InputError) as caught:
        load_cell(path)
    assert (caught.value.source, caught.value.line, caught.value.column) == (str(path), line, key)


@pytest.mark.parametrize("masses", [(25000.0, 28000.0), (280.0, 250.0), (0.25, 0.28), (0.0, 280.0), (1000.0, 1200.0)])
def test_the_cell_and_the_option_give_one_reason_for_one_range(data_dir, tmp_path, capsys, masses):
    low, high = masses
    path = _cell(data_dir, tmp_path, "kr270.toml", "mass_kg = [250.0, 280.0]", f"mass_kg = [{low!r}, {high!r}]")
    with pytest.raises(InputError) as caught:
        load_cell(path)
    assert main(["plan", "--config", str(data_dir / "kr270.toml"), "--mass-kg", f"{low!r}", f"{high!r}", "-o", str(tmp_path / "p.csv")]) == 2
    line = capsys.readouterr().err.strip()
    assert line == f"bayescal plan: error: --mass-kg: {caught.value.what}"
    assert not (tmp_path / "p.csv").exists()


from hypothesis import given  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

masses = st.floats(allow_nan=True, allow_infinity=True, min_value=None, max_value=None, width=64)


@given(low=masses, high=masses, capacity=st.floats(1.0, 1e4))
def test_a_mass_range_passes_exactly_when_positive_ordered_and_within_the_bounds(low, high, capacity):
    plausible = math.isfinite(low) and math.isfinite(high) and 0 < low <= high and 0.01 * capacity <= high <= 2 * capacity
    reason = mass_range_violation(low, high, capacity)
    assert (reason is None) == plausible, reason
    assert reason is None or "\n" not in reason
