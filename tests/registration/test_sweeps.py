import numpy as np
import pytest

from bayescal.errors import InputError
from bayescal.registration import read_sweeps

HEADER = "joint,q1_deg,q2_deg,marker,x_mm,y_mm,z_mm\n"


def _write(tmp_path, rows):
    path = tmp_path / "sweeps.csv"
    path.write_text("# sweeps\n" + HEADER + "".join(rows))
    return path


def _good_rows():
    return [f"1,{q},-90,A,{1000 + 5 * q},{200 + q},300\n" for q in (0, 10, 20)] + [
        f"2,0,{q},B,{1500 + q},{100 - q},{400 + q}\n" for q in (-80, -90, -100)
    ]


def test_reads_sweeps_in_si(tmp_path):
    sweeps = read_sweeps(_write(tmp_path, _good_rows()))
    assert sweeps.swept_joints == [0, 1]
    assert sweeps.q.shape == (6, 2)
    assert sweeps.xyz[0] == pytest.approx([1.0, 0.2, 0.3])
    assert sweeps.q[3, 1] == pytest.approx(np.radians(-80))


def test_two_joints_moving_names_line_and_column(tmp_path):
    rows = _good_rows()
    rows[2] = "1,20,-85,A,1100,220,300\n"
    with pytest.raises(InputError, match=r"sweeps.csv:5.*q2_deg.*joint 2 moves"):
        read_sweeps(_write(tmp_path, rows))


def test_fewer_than_three_angles(tmp_path):
    rows = _good_rows()
    rows[2] = "1,10,-90,A,1100,220,301\n"
    with pytest.raises(InputError, match=r"reflector 'A' is read at 2 angle"):
        read_sweeps(_write(tmp_path, rows))


def test_joint_out_of_range(tmp_path):
    rows = _good_rows()
    rows[0] = "3,0,-90,A,1000,200,300\n"
    with pytest.raises(InputError, match=r"sweeps.csv:3.*'joint'.*1 … 2"):
        read_sweeps(_write(tmp_path, rows))
