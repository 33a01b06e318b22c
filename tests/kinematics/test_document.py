"""Tests for bayescal/kinematics/document.py: a kinematic calibration's document, rigid or on an elastostatic deflection."""

import numpy as np

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.kinematics import KinematicCalibration, load_points_cell, read_positions
from bayescal.kinematics.document import HIDDEN_SHOWN
from bayescal.kinematics.elastic import ArmDeflection, ElasticKinematicCalibration
from bayescal.kinematics.from_campaign import campaign_positions
from bayescal.twin.kinematic_errors import KinematicErrors, with_kinematic_errors
from bayescal.twin.simulator import DigitalTwin

from .conftest import simulated, write_positions


def test_the_identified_parameters_are_tabled_and_the_others_named(justin, tmp_path):
    _, _, joints, xyz = simulated(justin, "geometry", np.random.default_rng(3), 60)
    positions = read_positions(write_positions(tmp_path / "positions.csv", justin, joints, xyz), justin)
    results = KinematicCalibration(justin, "geometry").fit(positions)
    document = results.document()
    d = results.diagnostics()
    assert document.title == (f"model 'geometry', {d['parameters']} parameters ({d['identified']} identified by the data), "
                              f"{d['configurations']} configurations")
    table = next(block for block in document.as_json()["lead"] if "table" in block)
    summary = results.summary()
    assert [row["parameter"] for row in table["rows"]] == list(summary.index[summary["identified"]])
    hidden = results.identifiability()
    text = document.as_text()
    assert sum(line.startswith("  ") and ": " in line for line in text.splitlines()) == min(len(hidden), HIDDEN_SHOWN)
    assert ("… and" in text) == (len(hidden) > HIDDEN_SHOWN)


def test_an_elastic_calibration_gives_its_refined_spring(data_dir):
    cell, points = load_cell(data_dir / "kr270.toml"), load_points_cell(data_dir / "robots" / "kr270_points.toml")
    twin = DigitalTwin(with_kinematic_errors(cell, KinematicErrors.draw(cell.robot, np.random.default_rng(5))))
    campaign = twin.simulate(read_plan(data_dir / "table3_plan.csv", cell.robot), 1, np.random.default_rng(6))
    positions, *_ = campaign_positions(campaign, points)
    start = ArmDeflection(cell, points, compliances=cell.compliances, compensator=cell.compensator.with_spring(230e3, 0.55))
    results = ElasticKinematicCalibration(points, start, {"K_c": 100e3, "K_c_s0": 50e3, "gravity_scale": 0.5}).fit(positions)
    spring = results.spring()
    line = next(line for line in results.document().as_text().splitlines() if line.startswith("the spring"))
    assert f"K_c = {spring['K_c'][0]:.1f} ± {spring['K_c'][1]:.1f} N/mm" in line and f"s0 = {spring['s0'][0]:.1f}" in line
