import numpy as np
import pytest

from bayescal.cell.nests import Nests, read_nests, require_times
from bayescal.errors import InputError

GOOD = "# nests of a test cell\nnest,t_s,x_mm,y_mm,z_mm\nN1,0,2500,0,0\nN2,20,-1250,2165,0\nN1,600,2500.01,0.02,-0.01\nN2,620,-1250,2165.03,0\n"


def write(tmp_path, text):
    path = tmp_path / "nests.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_reads_names_times_and_positions_in_si(tmp_path):
    nests = read_nests(write(tmp_path, GOOD))
    assert list(nests.name) == ["N1", "N2", "N1", "N2"]
    assert nests.times.tolist() == [0.0, 20.0, 600.0, 620.0]
    assert nests.position[2] == pytest.approx([2.50001, 0.00002, -0.00001])
    assert nests.lines.tolist() == [3, 4, 5, 6]


def test_written_file_reads_back(tmp_path):
    nests = Nests(np.array(["A", "A"]), np.array([1.5, 301.0]), np.array([[1.0, 2.0, 0.5], [1.00001, 2.0, 0.5]]), np.zeros(2, int))
    nests.write(tmp_path / "out.csv", ("written by a test",))
    back = read_nests(tmp_path / "out.csv")
    assert back.times.tolist() == [1.5, 301.0] and np.allclose(back.position, nests.position, atol=1e-8)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (GOOD.replace("t_s", "time"), "missing column 't_s'"),
        (GOOD.replace("2500.01", "abc"), "x_mm"),
        (GOOD.replace("N1,600", "N1,0"), "already read at t_s = 0"),
        ("nest,t_s,x_mm,y_mm,z_mm\nN1,0,1,2,3\nN1,60,1,2,3\nN2,0,3,2,1\n", "nest 'N2' is read at one time only"),
    ],
)
def test_bad_files_name_the_line_and_what_was_expected(tmp_path, text, expected):
    with pytest.raises(InputError, match=expected) as caught:
        read_nests(write(tmp_path, text))
    assert "nests.csv" in str(caught.value) and "\n" not in str(caught.value)


def test_a_campaign_without_times_is_refused_for_nests():
    with pytest.raises(InputError, match="needs the campaign's reading times: add the columns t0_s, t1_s"):
        require_times(None, "campaign.csv")
    require_times(np.zeros((2, 2)), "campaign.csv")
