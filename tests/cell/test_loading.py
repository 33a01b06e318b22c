"""Tests of bayescal.cell.loading and of the plan files' force and couple columns."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.cell.loading import Loading
from bayescal.cell.plan import Plan, read_plan, write_plan
from bayescal.errors import InputError

HEADER = "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg"
POSE = "0,-45,30,0,20,0"


@pytest.fixture(scope="module")
def any_cell(data_dir):
    return load_cell(data_dir / "kr270_any_load.toml")


def _plan(tmp_path, columns, *rows):
    path = tmp_path / "p.csv"
    path.write_text("\n".join([HEADER + "".join("," + c for c in columns)] + [POSE + "," + row for row in rows]) + "\n")
    return path


def test_the_cells_say_what_their_end_effector_applies(cell, any_cell):
    assert cell.loading == Loading() and cell.loading.hanging_only
    assert any_cell.loading == Loading(directions="any", force_max=2750.0, couple_max=500.0)


def test_a_hanging_mass_is_a_downward_force_through_the_load_point(cell):
    q = np.radians([10.0, -45.0, 30.0, 5.0, 20.0, 40.0])
    np.testing.assert_allclose(cell.wrench(q, [0.0, 0.0, -265.0 * cell.gravity]), cell.load_wrench(q, 265.0))
    # the couple of a force through the load point is its moment about the flange origin
    rotation, _ = cell.robot.flange_pose(q)
    wrench = cell.wrench(q, [1000.0, 0.0, 0.0], [0.0, 0.0, 50.0])
    np.testing.assert_allclose(wrench[3:], np.cross(rotation @ cell.load_point, [1000.0, 0.0, 0.0]) + [0.0, 0.0, 50.0])


def test_force_columns_are_read_and_written_back(tmp_path, any_cell):
    path = _plan(tmp_path, ["fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm"], "1000,-2000,500,0,300,-100")
    plan = read_plan(path, any_cell.robot, loading=any_cell.loading)
    assert plan.load_kg is None
    np.testing.assert_allclose(plan.forces(265.0, 9.81), [[1000.0, -2000.0, 500.0]])
    np.testing.assert_allclose(plan.couples(), [[0.0, 300.0, -100.0]])
    out = tmp_path / "out.csv"
    write_plan(plan, out)
    again = read_plan(out, any_cell.robot, loading=any_cell.loading)
    np.testing.assert_allclose(again.force, plan.force)
    np.testing.assert_allclose(again.couple, plan.couple)
    np.testing.assert_allclose(again.wrenches(any_cell), plan.wrenches(any_cell))


def test_a_mass_plan_gives_the_weight(cell, plan):
    forces = plan.forces(cell.load_mass, cell.gravity)
    np.testing.assert_allclose(forces[:, 2], -plan.load_kg * cell.gravity)
    np.testing.assert_allclose(plan.wrenches(cell)[3], cell.load_wrench(plan.q[3], plan.load_kg[3]))


@pytest.mark.parametrize(
    "columns, row, cell_name, message",
    [
        (["fx_N", "fy_N", "fz_N"], "2000,2000,0", "any", r"p.csv:2, column 'fx_N': a force of 2828.4 N is more than .*force_max_N = 2750 N"),
        (["fx_N", "fy_N", "fz_N"], "500,0,-2000", "down", r"p.csv:2, column 'fz_N': the force .* is not straight down.*hangs masses only"),
        (["fx_N", "fy_N", "fz_N"], "0,0,2000", "down", r"p.csv:2.*not straight down"),
        (["load_kg", "mx_Nm", "my_Nm", "mz_Nm"], "250,0,100,0", "down", r"p.csv:2, column 'my_Nm': a couple of 100.0 N m.*applies none"),
        (["fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm"], "0,0,-100,900,0,0", "any", r"column 'mx_Nm': a couple of 900.0 N m is more than .*500"),
        (["fx_N", "fy_N"], "0,0", "any", r"p.csv:1, column 'fz_N': missing column fz_N"),
        (["load_kg", "fx_N", "fy_N", "fz_N"], "250,0,0,-100", "any", r"p.csv:1, column 'load_kg': expected either load_kg .* or fx_N"),
        (["fx_N", "fy_N", "fz_N"], "0,0,-2000000", "any", r"more than the weight .* another unit than N"),
    ],
)
def test_loads_the_end_effector_cannot_apply(tmp_path, cell, any_cell, columns, row, cell_name, message):
    chosen = any_cell if cell_name == "any" else cell
    path = _plan(tmp_path, columns, row)
    with pytest.raises(InputError, match=message) as caught:
        read_plan(path, chosen.robot, max_load_kg=chosen.max_force / chosen.gravity, loading=chosen.loading)
    assert "\n" not in str(caught.value)


def test_a_vertical_force_is_a_hanging_load(tmp_path, cell):
    plan = read_plan(_plan(tmp_path, ["fx_N", "fy_N", "fz_N"], "0,0,-2500"), cell.robot, loading=cell.loading)
    np.testing.assert_allclose(plan.wrenches(cell)[0], cell.load_wrench(plan.q[0], 2500.0 / cell.gravity))


@pytest.mark.parametrize(
    "new, message",
    [
        ('directions = "sideways"', r"column 'load.directions'.*\"down\".*\"any\""),
        ('directions = "any"', r"missing key 'force_max_N'"),
        ("couple_max_Nm = -1.0", r"couple_max_Nm.*>= 0"),
        ("force_max_N = 0.0", r"force_max_N.*positive"),
    ],
)
def test_a_bad_load_table_names_its_key(tmp_path, data_dir, new, message):
    text = (data_dir / "kr270.toml").read_text().replace("gravity_m_per_s2 = 9.80665", "gravity_m_per_s2 = 9.80665\n" + new)
    path = tmp_path / "cell.toml"
    path.write_text(text)
    (tmp_path / "robots").symlink_to(data_dir / "robots")
    with pytest.raises(InputError, match=message):
        load_cell(path)


def test_loading_rejects_an_unknown_kind():
    with pytest.raises(ValueError):
        Loading(directions="up")
    assert Loading(directions="any", force_max=100.0).force_violation([0.0, 100.05, 0.0]) is None
    assert Loading().couple_violation(np.zeros(3)) is None
    assert isinstance(Plan(q=np.zeros((1, 6)), load_kg=None, lines=np.zeros(1, dtype=int)).describe_load(0, 265.0), str)
