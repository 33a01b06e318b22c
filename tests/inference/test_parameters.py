"""The parameter registry (inference.parameters): names, units, SI factors, published values, per-angle labels."""

import math

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.inference.parameters import ParameterRegistry, angle_label, is_per_angle_variable, label_angle, label_joint


def test_the_kr270_has_its_table_iv_and_its_labels_on_joint_2(cell):
    registry = ParameterRegistry.of_cell(cell)
    assert registry.names == ["k1", "k2", "k3", "k4", "k5", "k6", "K_c", "s0"]
    assert registry.units["k4"] == "urad/(N m)" and registry.units["K_c"] == "N/mm" and registry.units["s0"] == "mm"
    # Table IV as data/paper_reference.csv holds it; k1 is not in it.
    assert registry["K_c"].published == (144.0, 31.0) and registry["k2"].published == (0.302, 0.004)
    assert registry["k1"].published is None
    assert registry["K_c"].to_si(144.0) == pytest.approx(144e3) and registry["k2"].to_edge(0.302e-6) == pytest.approx(0.302)
    assert registry.per_angle_variable == "k2_q2" and registry.angle_dimension == "q2_deg"
    assert registry.angle_label(math.radians(-25.24)) == "k2_q2[-25.240]"


@pytest.mark.parametrize(
    ("name", "joints", "spring", "per_angle"),
    [("arm6", 6, False, None), ("arm6_j3", 6, True, "k3_q3"), ("arm7", 7, True, "k2_q2"), ("track_arm6", 7, True, "k3_q3")],
)
def test_every_test_robot_has_its_own_parameters(data_dir, name, joints, spring, per_angle):
    cell = load_cell(data_dir / "robots" / f"{name}.toml")
    registry = ParameterRegistry.of_cell(cell)
    assert [n for n in registry.names if n.startswith("k")] == [f"k{j + 1}" for j in range(joints)]
    assert ("K_c" in registry) == spring and ("s0" in registry) == spring
    assert registry.per_angle_variable == per_angle
    # No published values for a cell that names none.
    assert all(p.published is None for p in registry.parameters)
    for j in range(joints):
        expected = "um/N" if cell.robot.prismatic[j] else "urad/(N m)"
        assert registry[f"k{j + 1}"].unit == expected


def test_a_robot_without_a_compensator_has_no_per_angle_label(data_dir):
    registry = ParameterRegistry.of_cell(load_cell(data_dir / "robots" / "arm6.toml"))
    with pytest.raises(ValueError, match="no per-angle"):
        registry.angle_label(0.3)
    with pytest.raises(KeyError):
        registry["K_c"]


def test_one_parser_reads_every_joints_labels():
    for joint in (1, 2, 3, 9):
        for degrees in (-140.0, -25.24, 0.0, 12.5):
            label = angle_label(math.radians(degrees), joint)
            assert label_angle(label) == pytest.approx(degrees, abs=5e-4)
            assert label_joint(label) == joint
    for other in ("k2", "K_c", "s0", "sigma[x]", "k2_q3[10.000]", "k2_q2", "k2_q2[ten]"):
        assert label_angle(other) is None and label_joint(other) is None
    assert is_per_angle_variable("k3_q3") and is_per_angle_variable("k2_q2")
    assert not is_per_angle_variable("k2_q3") and not is_per_angle_variable("k2")


def test_edge_and_si_are_inverse_for_arrays(cell):
    registry = ParameterRegistry.of_cell(cell)
    values = np.array([0.1, 1.0, 3.3])
    for parameter in registry.parameters:
        np.testing.assert_allclose(parameter.to_edge(parameter.to_si(values)), values)


def test_edge_values_name_each_si_value_in_its_edge_unit(cell, data_dir):
    registry = ParameterRegistry.of_cell(cell)
    values = registry.edge_values(np.arange(1, 7) * 1e-7, (144e3, 0.458))
    assert values == pytest.approx({"k1": 0.1, "k2": 0.2, "k3": 0.3, "k4": 0.4, "k5": 0.5, "k6": 0.6, "K_c": 144.0, "s0": 458.0})
    assert list(registry.edge_values(np.ones(6) * 1e-6)) == ["k1", "k2", "k3", "k4", "k5", "k6"]
    # a robot without a compensator has no spring to name
    bare = ParameterRegistry.of_cell(load_cell(data_dir / "robots" / "arm6.toml"))
    with pytest.raises(KeyError):
        bare.edge_values(np.ones(6) * 1e-6, (1.0, 1.0))
