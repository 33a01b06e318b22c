"""Numbers shown to a person: rounded to their uncertainty, in the unit a person thinks in."""

import math

from bayescal.numbers import decimals_for, deflection_mm, error_um, rounded_pair, with_uncertainty


def test_two_significant_digits_of_the_uncertainty_fix_the_mean_s_decimals():
    assert decimals_for(0.04321) == 3
    assert decimals_for(4.3) == 1
    assert decimals_for(43.0) == 0
    assert decimals_for(430.0) == 0
    assert with_uncertainty(1.23456, 0.04321, "mm") == "1.235 ± 0.043 mm"
    assert with_uncertainty(2.5931, 0.3333, "urad/(N m)") == "2.59 ± 0.33 urad/(N m)"
    assert with_uncertainty(1234.6, 56.7) == "1235 ± 57"


def test_an_uncertainty_that_rounds_up_to_a_new_digit_keeps_two_significant_digits():
    # 0.0996 rounds to 0.10: two digits, not the three of 0.100.
    assert with_uncertainty(1.0, 0.0996) == "1.00 ± 0.10"


def test_missing_or_zero_uncertainty_does_not_invent_digits():
    assert with_uncertainty(math.nan, 0.1) == "–"
    assert with_uncertainty(1.23456, math.nan, "N/mm") == "1.235 N/mm"
    assert decimals_for(0.0) == 0


def test_errors_are_shown_in_micrometres_and_deflections_in_millimetres():
    assert error_um(0.01234) == "12.3 μm"
    assert error_um(0.01234, 0.00071) == "12.34 ± 0.71 μm"
    assert deflection_mm(0.43219) == "0.432 mm"
    assert deflection_mm(0.43219, 0.0123) == "0.432 ± 0.012 mm"


def test_table_columns_get_the_same_rounding():
    assert rounded_pair(0.40643, 0.0874) == ("0.406", "0.087")
    assert rounded_pair(math.nan, 0.1) == ("–", "–")
    assert rounded_pair(2.0, math.inf) == ("2", "–")


def test_a_table_is_rounded_row_by_row_to_its_uncertainty():
    import pandas as pd

    from bayescal.numbers import fixed, table_texts

    frame = pd.DataFrame(
        {"mean": [0.30041, 3.0577, float("nan")], "±3σ": [0.002455, 0.0804, float("nan")], "pct": [0.8175, 2.63, float("nan")]},
        index=["k2", "k4", "k1"],
    )
    texts = table_texts(frame, {"mean": "±3σ", "±3σ": "±3σ"}, {"pct": fixed(1)})
    assert texts.loc["k2"].tolist() == ["0.3004", "0.0025", "0.8"]
    assert texts.loc["k4"].tolist() == ["3.058", "0.080", "2.6"]
    assert texts.loc["k1"].tolist() == ["–", "–", "–"]
    assert fixed(1)(-0.04) == "0.0"  # no sign the value does not have
