import math

import numpy as np
import pandas as pd
import pytest

from bayescal.errors import InputError
from bayescal.reference import beside_published, published, published_width_pct, read_paper_reference, width_3sd_pct


def test_tables_ii_and_iv_as_published():
    assert published("II")["L"] == (184.72, 0.06)
    assert published("II")["a_y"] == (120.30, 0.69)
    table_iv = published("IV")
    assert set(table_iv) == {"K_c", "s0", "k2", "k3", "k4", "k5", "k6"}
    assert read_paper_reference().loc["K_c", "unit"] == "N/mm"  # k_c = 0.144 read as N/μm
    # the relative widths Klimchik et al. print beside Table IV
    widths = {name: round(100 * half / value, 1) for name, (value, half) in table_iv.items()}
    assert widths == {"K_c": 21.5, "s0": 5.9, "k2": 1.3, "k3": 2.0, "k4": 3.8, "k5": 4.9, "k6": 4.0}


def test_unknown_table():
    with pytest.raises(ValueError, match="no Table III"):
        published("III")


def test_a_parameter_listed_twice_is_an_input_error(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text("table,parameter,unit,value,ci3\nII,L,mm,1,0.1\nII,L,mm,2,0.1\n")
    with pytest.raises(InputError, match="ref.csv:3, column 'parameter': parameter listed twice"):
        read_paper_reference(path)


def test_width_is_three_sd_in_percent_of_the_mean():
    assert width_3sd_pct(-2.0, 0.01) == pytest.approx(1.5)
    assert math.isinf(width_3sd_pct(np.float64(0.0), 1.0))
    np.testing.assert_allclose(width_3sd_pct(np.array([1.0, 4.0]), np.array([0.1, 0.1])), [30.0, 7.5])


def test_published_width_is_nan_for_a_parameter_the_table_does_not_list():
    assert published_width_pct("IV", "K_c") == pytest.approx(100 * 31 / 144)
    assert math.isnan(published_width_pct("IV", "k1"))


def test_estimates_beside_table_iv():
    estimates = pd.DataFrame({"mean": [0.31, 0.5, np.nan], "sd": [0.002, 0.1, np.nan]}, index=["k2", "k1", "s0"])
    frame = beside_published(estimates, "IV")
    assert list(frame.index) == ["k2", "k1", "s0"]
    k2 = frame.loc["k2"]
    assert k2["half_width_3sd"] == pytest.approx(0.006)
    assert k2["difference"] == pytest.approx(0.008)
    assert k2["difference_in_sd"] == pytest.approx(4.0)
    assert k2["difference_in_published_sd"] == pytest.approx(0.008 / (0.004 / 3))
    assert not k2["published_inside_3sd"]  # 0.302 lies 4 sd below 0.31
    assert math.isnan(frame.loc["k1", "published"])  # Table IV has no k1
    assert frame.loc["s0", "published"] == 458 and math.isnan(frame.loc["s0", "width_3sd_pct"])


def test_a_reference_file_other_than_the_repository_copy(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text("table,parameter,unit,value,ci3\nII,L,mm,180,0.3\n")
    estimates = pd.DataFrame({"mean": [180.1], "sd": [0.05]}, index=["L"])
    row = beside_published(estimates, "II", read_paper_reference(path)).loc["L"]
    assert row["published"] == 180 and row["published_width_pct"] == pytest.approx(100 * 0.3 / 180)
    assert row["published_inside_3sd"]
