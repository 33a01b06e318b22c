"""Tests of bayescal.cell.plan: Table III and plan validation."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.errors import InputError
from bayescal.cell.config import load_cell
from bayescal.cell.plan import position_columns, prismatic_flags, read_plan, write_plan


def test_table_iii(robot, data_dir):
    plan = read_plan(data_dir / "table3_plan.csv", robot)
    assert len(plan) == 15
    q2 = np.degrees(plan.q[:, 1]).reshape(5, 3)
    np.testing.assert_allclose(q2, np.repeat([[-0.01], [-25.24], [-56.9], [-99.85], [-140.0]], 3, axis=1))
    assert np.degrees(plan.q[7, 4]) == pytest.approx(-98.26)  # row 8 as printed
    assert np.all((plan.load_kg >= 250) & (plan.load_kg <= 280))
    assert plan.lines[0] == 8  # after six comment lines and the header


def test_masses_default_when_the_plan_has_none(tmp_path, robot):
    path = tmp_path / "p.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,-45,30,0,20,0\n")
    plan = read_plan(path, robot)
    assert plan.load_kg is None
    np.testing.assert_array_equal(plan.masses(265.0), [265.0])


def test_row_outside_the_joint_limits(tmp_path, robot):
    path = tmp_path / "p.csv"
    path.write_text("# note\nq1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,250\n0,-45,30,0,130,0,250\n")
    with pytest.raises(InputError) as caught:
        read_plan(path, robot)
    message = str(caught.value)
    assert "p.csv:4" in message and "q5_deg" in message and "A5" in message and "\n" not in message


def test_bad_load(tmp_path, robot):
    path = tmp_path / "p.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,-5\n")
    with pytest.raises(InputError, match=r"p.csv:2.*load_kg.*positive mass"):
        read_plan(path, robot)
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,nan\n")
    with pytest.raises(InputError, match=r"p.csv:2.*load_kg"):
        read_plan(path, robot)


def test_underscores_in_numbers_are_rejected(tmp_path, robot):
    # float("7_9.20") is 79.2: the plan cell must be an error, not a joint angle.
    path = tmp_path / "p.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,-7_9.20,30,0,20,0\n")
    with pytest.raises(InputError, match=r"p.csv:2, column 'q2_deg': expected a number in deg, got '-7_9.20'"):
        read_plan(path, robot)


def test_a_load_beyond_the_capacity_is_rejected(tmp_path, cell):
    path = tmp_path / "p.csv"
    path.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,265\n0,-45,30,0,20,0,2650\n")
    limit = cell.max_force / cell.gravity
    assert limit == pytest.approx(540.0)  # twice the KR-270's rated 270 kg
    assert len(read_plan(path, cell.robot)) == 2
    with pytest.raises(InputError, match=r"p.csv:3, column 'load_kg': a load of 2650 kg is more than the 540 kg"):
        read_plan(path, cell.robot, max_load_kg=limit)


def test_a_joint_column_the_robot_lacks_is_rejected(tmp_path, robot):
    path = tmp_path / "p.csv"
    path.write_text("# seven joints\nq1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,q7_deg\n0,-45,30,0,20,0,0\n")
    with pytest.raises(InputError, match=r"p.csv:2, column 'q7_deg': the plan has a column q7_deg but the robot .* has 6 joints"):
        read_plan(path, robot)
def test_written_plan_reads_back(tmp_path, robot, data_dir):
    plan = read_plan(data_dir / "table3_plan.csv", robot)
    path = tmp_path / "plan.csv"
    write_plan(plan, path, comments=["a provenance note"])
    again = read_plan(path, robot)
    assert path.read_text().startswith("# a provenance note\nq1_deg,")
    np.testing.assert_allclose(again.q, plan.q, atol=0.0005 * np.pi / 180)
    np.testing.assert_array_equal(again.load_kg, plan.load_kg)


def test_the_files_joint_columns_follow_the_robots_joints(cell, data_dir):
    columns, scale = position_columns(3, None)
    assert columns == ["q1_deg", "q2_deg", "q3_deg"] and np.allclose(scale, np.pi / 180)
    assert prismatic_flags(cell.robot) is None
    track = load_cell(data_dir / "robots" / "track_arm6.toml").robot
    flags = prismatic_flags(track)
    columns, scale = position_columns(track.nq, flags)
    # the files name each joint as the robot does, and the unit's SI value is 1 mm or 1 deg
    assert columns == list(track.position_columns) and columns[0] == "q1_mm"
    np.testing.assert_allclose(scale, np.where(flags, 1e-3, np.pi / 180))
    flags[0] = False  # a copy: the robot's own flags stay
    assert track.prismatic[0]
