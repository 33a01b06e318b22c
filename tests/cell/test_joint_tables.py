"""Tests of bayescal.cell.joint_tables: the one reader of joint-angle tables, and the readers built on it."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from bayescal.cell.campaign import read_campaign
from bayescal.cell.joint_tables import JointLayout, read_joint_table, robot_reach
from bayescal.compensation.program import read_program
from bayescal.errors import InputError
from bayescal.registration.sweeps import read_sweeps
from bayescal.units import DEG

PROPERTY = settings(max_examples=40, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _angles(robot, rows: int):
    """A strategy of ``(rows, nq)`` joint angles in deg within the robot's limits."""
    low, high = robot.lower / DEG, robot.upper / DEG
    row = st.tuples(*[st.floats(float(a), float(b), allow_nan=False, allow_infinity=False) for a, b in zip(low, high)])
    return st.lists(row, min_size=2, max_size=rows).map(np.array)


def _write(path, robot, angles, extra=""):
    header = ",".join(robot.position_columns) + ("," + extra.split("=")[0] if extra else "")
    cells = [",".join(repr(float(v)) for v in row) + ("," + extra.split("=")[1] if extra else "") for row in angles]
    path.write_text("\n".join([header, *cells]) + "\n")
    return path


def test_the_reach_is_the_sum_of_the_links(planar_arm, cell):
    assert robot_reach(planar_arm) == pytest.approx(1.5)
    assert robot_reach(cell.robot) == pytest.approx(3.735)


@PROPERTY
@given(data=st.data())
def test_degrees_within_the_limits_read_back_as_written(cell, tmp_path, data):
    robot = cell.robot
    angles = data.draw(_angles(robot, 12))
    assume(np.any(np.abs(angles) > JointLayout.of(robot).radian_bound))
    path = _write(tmp_path / "t.csv", robot, angles)
    frame, q = read_joint_table(path, JointLayout.of(robot), {}, what="table")
    assert np.array_equal(q, angles * DEG) and list(frame.index) == list(range(2, 2 + len(angles)))


@PROPERTY
@given(data=st.data())
def test_a_radian_copy_of_any_table_is_refused_as_radians(cell, tmp_path, data):
    robot = cell.robot
    angles = data.draw(_angles(robot, 12))
    assume(np.unique(np.radians(angles), axis=0).shape[0] >= 2)
    path = _write(tmp_path / "t.csv", robot, np.radians(angles))
    with pytest.raises(InputError, match=r"t\.csv:2, column 'q1_deg': every joint angle of the \d+ configurations lies within ±3\.2 deg.*as angles in radians would"):
        read_joint_table(path, JointLayout.of(robot), {}, what="table")


@PROPERTY
@given(data=st.data(), column=st.sampled_from(["q7_deg", "q2_rad", "q0_deg", "q12_mm"]))
def test_a_joint_column_the_robot_does_not_have_is_named(cell, tmp_path, data, column):
    robot = cell.robot
    angles = data.draw(_angles(robot, 4))
    path = _write(tmp_path / "t.csv", robot, angles, extra=f"{column}=0")
    with pytest.raises(InputError, match=rf"t\.csv:1, column '{column}': the table has a column {column}"):
        read_joint_table(path, JointLayout.of(robot), {}, what="table")


@PROPERTY
@given(junk=st.binary(max_size=400))
def test_junk_bytes_raise_nothing_but_an_input_error(cell, tmp_path, junk):
    path = tmp_path / "junk.csv"
    path.write_bytes(junk)
    for read in (
        lambda: read_joint_table(path, JointLayout.of(cell.robot), {"marker": "text"}, what="table"),
        lambda: read_program(path, cell),
        lambda: read_campaign(path, cell=cell),
        lambda: read_sweeps(path, cell.robot),
    ):
        try:
            read()
        except InputError as error:
            assert "\n" not in str(error) and str(error).startswith(str(path))
    assert path.read_bytes() == junk


@PROPERTY
@given(data=st.data(), cell_text=st.sampled_from(["", "nan", "inf", "1e400", "7_9", "abc", "-0", "1e-300", "١"]))
def test_junk_cells_in_a_good_program_raise_nothing_but_an_input_error(cell, tmp_path, data, cell_text):
    robot = cell.robot
    angles = data.draw(_angles(robot, 5))
    rows = [[repr(float(v)) for v in row] + ["-800", "0", "0", "0", "0", "0"] for row in angles]
    rows[data.draw(st.integers(0, len(rows) - 1))][data.draw(st.integers(0, 11))] = cell_text
    path = tmp_path / "p.csv"
    path.write_text("\n".join([",".join([*robot.position_columns, "fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm"])] + [",".join(r) for r in rows]))
    try:
        program = read_program(path, cell)
    except InputError as error:
        assert "\n" not in str(error) and str(error).startswith(str(path))
    else:
        assert np.isfinite(program.q).all() and np.isfinite(program.wrench).all()
