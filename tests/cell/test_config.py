"""Tests of bayescal.cell.config: the KR-270 cell file and the TOML validation."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.errors import InputError


def test_kr270_cell_in_si(cell):
    np.testing.assert_allclose(cell.compliances, np.array([0.30, 0.302, 0.406, 3.002, 3.303, 2.365]) * 1e-6)
    compensator = cell.compensator
    assert compensator.K_c == pytest.approx(144e3)
    assert compensator.s0 == pytest.approx(0.458)
    assert (compensator.L, compensator.a_x, compensator.a_y) == pytest.approx((0.18472, 0.68593, 0.12030))
    assert 99 < math.degrees(compensator.phi) < 101  # Table I: the lever points almost straight up at q2 = 0
    assert set(cell.markers) == {"M1", "M2", "M3"}
    assert cell.tracker.U0 == pytest.approx(15e-6) and cell.tracker.U1 == pytest.approx(6e-6)
    assert cell.test_wrench.shape == (6,) and cell.test_q.shape == (6,)


def test_markers_and_load_are_off_the_a6_axis(cell):
    for point in [*cell.markers.values(), cell.load_point]:
        assert np.hypot(point[1], point[2]) > 0.1
    spacing = [np.linalg.norm(a - b) for a in cell.markers.values() for b in cell.markers.values() if a is not b]
    assert min(spacing) == pytest.approx(0.2, abs=1e-4)


def test_load_wrench_is_a_hanging_mass(cell):
    q = np.radians([10, -30, 20, 40, -50, 60])
    wrench = cell.load_wrench(q, 265.0)
    np.testing.assert_allclose(wrench[:3], [0, 0, -265.0 * 9.80665])
    rotation, origin = cell.robot.flange_pose(q)
    np.testing.assert_allclose(wrench[3:], np.cross(rotation @ cell.load_point, wrench[:3]))


def test_test_pose_wrench_is_the_tip_force(cell):
    rotation, _ = cell.robot.flange_pose(cell.test_q)
    force = cell.test_wrench[:3]
    np.testing.assert_allclose(cell.test_wrench[3:], np.cross(rotation @ cell.test_point, force), atol=1e-6)


def _edited(data_dir, tmp_path, old, new):
    shutil.copytree(data_dir / "robots", tmp_path / "robots")
    text = (data_dir / "kr270.toml").read_text()
    assert old in text
    path = tmp_path / "cell.toml"
    path.write_text(text.replace(old, new))
    return path


def _line_of(path, needle):
    return next(i for i, line in enumerate(path.read_text().splitlines(), start=1) if line.startswith(needle))


def test_bad_values_name_the_line_and_key(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, "K_c_N_per_mm = 144.0", 'K_c_N_per_mm = "stiff"')
    with pytest.raises(InputError) as caught:
        load_cell(path)
    assert f"cell.toml:{_line_of(path, 'K_c_N_per_mm')}" in str(caught.value)
    assert "compensator.K_c_N_per_mm" in str(caught.value) and "N/mm" in str(caught.value)


def test_wrong_number_of_compliances(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, "k_urad_per_Nm = [0.30, ", "k_urad_per_Nm = [")
    with pytest.raises(InputError, match=r"joints.k_urad_per_Nm.*list of 6 numbers"):
        load_cell(path)


def test_missing_urdf_and_test_pose_outside_limits(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, 'urdf = "robots/kr270.urdf"', 'urdf = "robots/none.urdf"')
    with pytest.raises(InputError, match="robot.urdf"):
        load_cell(path)
    path = _edited(data_dir, tmp_path / "b", "q_deg = [0.0, -50.0", "q_deg = [0.0, 50.0")
    with pytest.raises(InputError, match=r"test_pose.q_deg.*A2"):
        load_cell(path)


def test_cell_without_compensator(tmp_path, data_dir):
    text = (data_dir / "kr270.toml").read_text()
    start, end = text.index("[compensator]"), text.index("[tool]")
    shutil.copytree(data_dir / "robots", tmp_path / "robots")
    path = tmp_path / "plain.toml"
    path.write_text(text[:start] + text[end:])
    assert load_cell(path).compensator is None


def test_not_toml(tmp_path):
    path = tmp_path / "x.toml"
    path.write_text("[robot\n")
    with pytest.raises(InputError, match="not a valid TOML"):
        load_cell(path)


@pytest.mark.parametrize(
    ("old", "new", "column"),
    [
        ("M1 = [200.0, 0.0, 115.47]", "M1 = [200000.0, 0.0, 115.47]", "tool.markers_mm.M1"),
        ("L_mm = 184.72", "L_mm = 184720", "compensator.L_mm"),
    ],
)
def test_a_marker_beyond_any_tool_or_a_linkage_beyond_any_arm_is_refused(tmp_path, data_dir, old, new, column):
    text = (data_dir / "kr270.toml").read_text().replace('urdf = "', f'urdf = "{data_dir}/')
    assert old in text
    path = tmp_path / "cell.toml"
    path.write_text(text.replace(old, new))
    with pytest.raises(InputError, match=rf"column '{column}': .* is it in μm instead of mm\?"):
        load_cell(path)


def test_unknown_flange_frame_names_the_flange_key(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, 'flange = "flange"', 'flange = "tool0"')
    with pytest.raises(InputError, match=r"cell.toml:\d+, column 'robot.flange': the model has no frame named 'tool0'"):
        load_cell(path)


@pytest.mark.parametrize(
    ("old", "new", "needle", "message"),
    [
        ("factor = 0.8", "factr = 0.1", "factr", "column 'tracker.factr': unknown key 'factr' in [tracker]; did you mean 'factor'?"),
        ("[tracker]", "[trackr]", "[trackr]", "column 'trackr': unknown table [trackr]; did you mean [tracker]?"),
        ("mass_kg = 265.0", "mass_kg = 265.0\nmas_kg = 1.0", "mas_kg", "unknown key 'mas_kg' in [load]; did you mean 'mass_kg'?"),
        ("K_c_N_per_mm = 144.0", "K_c_N_per_mm = -144.0", "K_c_N_per_mm", "column 'compensator.K_c_N_per_mm': expected a number >= 0 in N/mm, got -144.0"),
        ("payload_kg = 270.0", "payload_kg = 0", "payload_kg", "column 'robot.payload_kg': expected a positive number in kg"),
        ("wrench_N_Nm = [-1000.0,", "wrench_N_Nm = [-1e7,", "wrench_N_Nm", "more than the 5296 N the robot can plausibly hold"),
    ],
)
def test_mistakes_name_the_line_and_key(tmp_path, old, new, needle, message, data_dir):
    path = _edited(data_dir, tmp_path, old, new)
    with pytest.raises(InputError) as caught:
        load_cell(path)
    text = str(caught.value)
    assert message in text and f"cell.toml:{_line_of(path, needle)}," in text and "\n" not in text


def test_a_key_outside_any_table_is_unknown(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, "[robot]", 'factor = 0.1\n[robot]')
    with pytest.raises(InputError, match=r"cell.toml:\d+, column 'factor': unknown key 'factor' outside any table"):
        load_cell(path)


def test_latin1_byte_names_its_line(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, "# Leica AT901", "# Leica AT901")
    raw = path.read_bytes().replace(b"# Leica AT901", b"# Leica AT901 \xb1", 1)
    path.write_bytes(raw)
    line = raw[: raw.index(b"AT901 \xb1")].count(b"\n") + 1  # the file's own "±" is UTF-8 (0xc2 0xb1)
    with pytest.raises(InputError, match=rf"cell.toml:{line}: byte 0xb1 is not UTF-8 text .*save the file as UTF-8"):
        load_cell(path)


def test_byte_order_mark_is_accepted(tmp_path, data_dir):
    path = _edited(data_dir, tmp_path, "[robot]", "[robot]")
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert load_cell(path).payload_kg == 270.0


def test_a_folder_is_not_a_missing_file(tmp_path):
    with pytest.raises(InputError, match="is a folder; expected a cell TOML file"):
        load_cell(tmp_path)


def test_capacity_is_the_larger_of_payload_and_load(cell, tmp_path, data_dir):
    assert cell.capacity_weight == pytest.approx(270.0 * 9.80665)
    path = _edited(data_dir, tmp_path, "payload_kg = 270.0\n", "")
    assert load_cell(path).capacity_weight == pytest.approx(265.0 * 9.80665)


@pytest.mark.parametrize(
    ("content", "message"),
    [("not xml\n", r"kr270.urdf:1: not a URDF: not valid XML"), ("<foo/>\n", r"kr270.urdf:1: not a URDF: the root element is <foo>")],
)
def test_a_urdf_that_is_not_one_gives_one_line(tmp_path, capfd, content, message, data_dir):
    path = _edited(data_dir, tmp_path, "[robot]", "[robot]")
    (tmp_path / "robots" / "kr270.urdf").write_text(content)
    with pytest.raises(InputError, match=message):
        load_cell(path)
    assert capfd.readouterr().err == ""  # the URDF parser did not get to print its own lines


def test_the_design_table_is_read_in_si(cell):
    assert cell.design.mass_range == (250.0, 280.0)
    assert cell.design.acceptance == pytest.approx(math.radians(60.0))
    assert cell.design.floor_z == 0.0


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("acceptance_deg = 60.0", "acceptance_deg = 120.0", r"an angle in deg in \(0, 90\]"),
        ("mass_kg = [250.0, 280.0]", "mass_kg = [280.0, 250.0]", "the lighter mass first, got 280 kg then 250 kg"),
        ("mass_kg = [250.0, 280.0]", "mass_kg = 250.0", "a list of 2 numbers"),
    ],
)
def test_a_malformed_design_table_names_its_line(tmp_path, data_dir, old, new, expected):
    path = _edited(data_dir, tmp_path, old, new)
    key = new.split(" =")[0]
    with pytest.raises(InputError, match=rf"cell.toml:{_line_of(path, new)}, column 'design.{key}': expected .*{expected}"):
        load_cell(path)


def test_the_machining_tool_point_defaults_to_the_test_pose_point(cell, tmp_path, data_dir):
    assert cell.tcp is None and np.array_equal(cell.tool_point, cell.test_point)
    (tmp_path / "good").mkdir()
    (tmp_path / "bad").mkdir()
    path = _edited(data_dir, tmp_path / "good", "load_point_mm = [250.0, 0.0, 300.0]", "load_point_mm = [250.0, 0.0, 300.0]\ntcp_mm = [410.0, 0.0, 25.0]")
    assert load_cell(path).tool_point == pytest.approx([0.410, 0.0, 0.025])
    bad = _edited(data_dir, tmp_path / "bad", "load_point_mm = [250.0, 0.0, 300.0]", "load_point_mm = [250.0, 0.0, 300.0]\ntcp_mm = [410.0, 0.0]")
    with pytest.raises(InputError, match="tcp_mm"):
        load_cell(bad)


def _robot_cell(data_dir, tmp_path, name, old="", new=""):
    """A test robot's cell (data/robots/) with ``old`` replaced by ``new``, beside a copy of its URDFs."""
    shutil.copytree(data_dir / "robots", tmp_path / "robots", dirs_exist_ok=True)
    path = tmp_path / "robots" / f"{name}-edited.toml"
    text = (data_dir / "robots" / f"{name}.toml").read_text()
    assert old in text
    path.write_text(text.replace(old, new))
    return path


def test_the_compensator_sits_on_the_joint_the_cell_names(data_dir):
    assert load_cell(data_dir / "robots" / "arm6_j3.toml").compensated_joint == 2
    assert load_cell(data_dir / "robots" / "arm6.toml").compensated_joint is None
    assert load_cell(data_dir / "kr270.toml").compensated_joint == 1


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("joint = 3", "joint = 8", "expected a joint number from 1 to 6"),
        ("joint = 3", "joint = 2.5", "expected a joint number from 1 to 6"),
        ("k_urad_per_Nm = [0.60, 0.50, 0.80, 4.00, 4.50, 3.50]", "k_urad_per_Nm = [0.60, 0.50]", "a list of 6 numbers"),
        ('urdf = "arm6.urdf"', 'urdf = "arm6_gripper.urdf"', r'joints = \["J1", "J2", "J3", "J4", "J5", "J6"\]'),
    ],
)
def test_robot_and_compensator_mistakes_are_one_line(data_dir, tmp_path, old, new, message):
    with pytest.raises(InputError, match=message):
        load_cell(_robot_cell(data_dir, tmp_path, "arm6_j3", old, new))


def test_a_gripper_is_locked_once_the_chain_is_named(data_dir, tmp_path):
    chain = 'urdf = "arm6_gripper.urdf"\njoints = ["J1", "J2", "J3", "J4", "J5", "J6"]\nlocked_mm = { finger_left = 20.0 }'
    cell = load_cell(_robot_cell(data_dir, tmp_path, "arm6", 'urdf = "arm6.urdf"', chain))
    assert cell.robot.nq == 6 and cell.robot.joint_names[-1] == "J6"
    with pytest.raises(InputError, match="robot.locked_mm.*'J1' is in the chain and cannot also be locked"):
        load_cell(_robot_cell(data_dir, tmp_path, "arm6", 'urdf = "arm6.urdf"', chain.replace("finger_left", "J1")))
    with pytest.raises(InputError, match="robot.locked_deg.*not a revolute joint"):
        load_cell(_robot_cell(data_dir, tmp_path, "arm6", 'urdf = "arm6.urdf"', chain.replace("locked_mm", "locked_deg")))


def test_a_linear_track_reads_its_position_in_mm_and_its_compliance_in_um_per_N(data_dir, tmp_path):
    cell = load_cell(data_dir / "robots" / "track_arm6.toml")
    assert cell.robot.position_columns[0] == "q1_mm" and cell.test_q[0] == pytest.approx(2.0)
    assert cell.compliances[0] == pytest.approx(0.01e-6) and cell.compliances[1] == pytest.approx(0.60e-6)
    with pytest.raises(InputError, match="a list of 1 numbers in um_per_N for T1"):
        load_cell(_robot_cell(data_dir, tmp_path, "track_arm6", "k_um_per_N = [0.01]", "k_um_per_N = [0.01, 0.02]"))
    with pytest.raises(InputError, match="no prismatic joint"):
        load_cell(_robot_cell(data_dir, tmp_path, "arm6", "k_urad_per_Nm", "k_um_per_N = [1.0]\nk_urad_per_Nm"))


TOOL_LINE = "load_point_mm = [250.0, 0.0, 300.0]"


def test_a_weighed_tool_enters_the_unloaded_torques_and_none_leaves_them_as_they_were(cell, tmp_path, data_dir):
    from bayescal.critique.covariates import _static_torque as torque_in

    def _static_torque(of, q):
        return torque_in(of, q, of.robot.workspace())

    (tmp_path / "tool").mkdir()
    (tmp_path / "zero").mkdir()
    weighed = load_cell(_edited(data_dir, tmp_path / "tool", TOOL_LINE, TOOL_LINE + "\nmass_kg = 38.0\ncom_mm = [170.0, 0.0, 90.0]"))
    zero = load_cell(_edited(data_dir, tmp_path / "zero", TOOL_LINE, TOOL_LINE + "\nmass_kg = 0.0"))
    assert weighed.robot.tool_mass == 38.0 and weighed.robot.tool_centre == pytest.approx([0.17, 0.0, 0.09])
    q = np.radians([10.0, -60.0, 70.0, 30.0, -40.0, 20.0])
    # the joints carry the tool's weight at its centre of mass: J_cᵀ m g more than without it
    weight = -38.0 * np.array(cell.robot.model.gravity.linear)
    extra = cell.robot.point_jacobian(q, [0.17, 0.0, 0.09]).T @ weight
    assert _static_torque(weighed, q) - _static_torque(cell, q) == pytest.approx(-extra, abs=1e-9)
    assert np.abs(extra[3:]).max() > 10.0
    assert np.array_equal(_static_torque(zero, q), _static_torque(cell, q)) and zero.robot.tool_mass == 0.0


@pytest.mark.parametrize(
    ("new", "key", "message"),
    [
        ("mass_kg = -5.0\ncom_mm = [170.0, 0.0, 90.0]", "mass_kg", "expected a number >= 0 in kg"),
        ("mass_kg = 38000.0\ncom_mm = [170.0, 0.0, 90.0]", "mass_kg", "a tool of 38000 kg is heavier than the 270 kg the robot carries"),
        ("mass_kg = 38.0", "[tool]", "missing key 'com_mm'"),
        ("com_mm = [170.0, 0.0, 90.0]", "com_mm", "a centre of mass without the tool's mass"),
        ("mass_kg = 38.0\ncom_mm = [170.0, 0.0]", "com_mm", "expected a list of 3 numbers in mm"),
        ("mass_kg = 38.0\ncom_mm = [170000.0, 0.0, 90.0]", "com_mm", "beyond any tool"),
    ],
)
def test_a_bad_tool_weight_is_one_line_naming_its_key(tmp_path, data_dir, new, key, message):
    path = _edited(data_dir, tmp_path, TOOL_LINE, TOOL_LINE + "\n" + new)
    with pytest.raises(InputError) as caught:
        load_cell(path)
    text = str(caught.value)
    assert message in text and f"cell.toml:{_line_of(path, key)}," in text and "\n" not in text
