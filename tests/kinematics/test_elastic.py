"""The kinematic calibration with an elastostatic model's deflection (the KR-270 and its spring compensator)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.errors import InputError
from bayescal.kinematics.cell import load_points_cell
from bayescal.kinematics.elastic import ArmDeflection, ElasticKinematicCalibration
from bayescal.kinematics.from_campaign import campaign_positions
from bayescal.twin.kinematic_errors import KinematicErrors, with_kinematic_errors
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def cell(data_dir):
    return load_cell(data_dir / "kr270.toml")


@pytest.fixture(scope="module")
def points(data_dir):
    return load_points_cell(data_dir / "robots" / "kr270_points.toml")


def _deflection(cell, points):
    return ArmDeflection(cell, points, compliances=cell.compliances, compensator=cell.compensator)


def test_the_deflection_is_the_twins_sag_and_its_load(cell, points):
    twin, deflection = DigitalTwin(cell), _deflection(cell, points)
    q = np.array([[0.3, -0.8, 0.6, 0.2, -0.4, 0.5], [-1.0, -1.9, 1.2, -0.5, 0.9, -2.0]])
    rigid = np.array([[cell.robot.point_position(qi, cell.markers[n]) for n in points.marker_names] for qi in q])
    exact = np.array([twin.positions(qi, 265.0) for qi in q])  # (N, 2, M, 3)
    wrenches = np.array([cell.load_wrench(qi, 265.0) for qi in q])
    assert np.abs(deflection(q) - (exact[:, 0] - rigid)).max() < 1e-10
    assert np.abs(deflection(q, wrenches) - (exact[:, 1] - rigid)).max() < 1e-10
    assert np.abs(exact[:, 0] - rigid).max() > 0.5e-3  # the sag matters at the tracker's tens of microns


def test_a_marker_the_elastostatic_cell_lacks_is_named(cell, points):
    with pytest.raises(InputError, match="marker 'M1'"):
        _deflection(dataclasses.replace(cell, markers={"other": np.zeros(3)}), points)


def test_table_iii_absolute_positions_identify_the_spring_and_the_errors(cell, points, data_dir):
    """Table III's 15 configurations, unloaded, with kinematic errors: the spring loaded-minus-unloaded cannot see."""
    errors = KinematicErrors.draw(cell.robot, np.random.default_rng(5))
    twin = DigitalTwin(with_kinematic_errors(cell, errors))
    campaign = twin.simulate(read_plan(data_dir / "table3_plan.csv", cell.robot), 1, np.random.default_rng(6))
    positions, *_ = campaign_positions(campaign, points)
    # The elastostatic medians a loaded-minus-unloaded campaign leaves: the compliances right, the spring 60 % off.
    start = ArmDeflection(cell, points, compliances=cell.compliances, compensator=cell.compensator.with_spring(230e3, 0.55))
    fit = ElasticKinematicCalibration(points, start, {"K_c": 100e3, "K_c_s0": 50e3, "gravity_scale": 0.5}).fit(positions)
    spring = fit.spring()
    for (mean, sd), truth in ((spring["K_c"], 144.0), (spring["s0"], 458.0), (tuple(fit.summary().loc["A5.ty", ["mean", "sd"]]),
                                                                               errors.deltas[4, 1] * 1e3)):
        assert abs(mean - truth) < 3 * sd, truth
    assert spring["K_c"][1] < 5.0  # N/mm: the loaded-minus-unloaded campaign leaves ±100
    assert fit.kinematic.model_sd < 20e-6  # m; measured 10.8 μm on top of the tracker's 32-44
