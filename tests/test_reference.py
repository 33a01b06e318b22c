import pytest

from bayescal.errors import InputError
from bayescal.reference import published, read_paper_reference


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
