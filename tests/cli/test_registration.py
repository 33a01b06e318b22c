"""``--registration`` on calibrate, geometry, critique and report: tracker-frame files moved into the robot's frames."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

import bayescal.cli as cli
from bayescal.cell.campaign import write_campaign
from bayescal.registration import read_sweeps, register
from bayescal.registration.frames import paper_frame, urdf_axes
from bayescal.twin.simulator import DigitalTwin
from bayescal.twin.sweeps import TrackerPlacement, simulate_sweeps
from bayescal.units import DEG, MM
from tests.conftest import DATA

HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]
CONFIG = str(DATA / "kr270.toml")
QUICK = ["--model", "linear", "--draws", "100", "--json"]


@pytest.fixture(scope="module")
def files(cell, plan, tmp_path_factory):
    """A Table III campaign and Table I's arcs read by a tracker turned 5.4°, its sweeps' registration, the base campaign."""
    folder = tmp_path_factory.mktemp("registration")
    rng = np.random.default_rng(8)
    axis = rng.normal(size=3)
    placement = TrackerPlacement(Rotation.from_rotvec(5.4 * DEG * axis / np.linalg.norm(axis)).as_matrix(), cell.tracker.position)
    campaign = DigitalTwin(cell).simulate(plan, 1, rng)
    write_campaign(campaign, folder / "base.csv")
    write_campaign(replace(campaign, p0=placement.to_tracker(campaign.p0), p1=placement.to_tracker(campaign.p1)), folder / "tracker.csv")
    simulate_sweeps(cell, placement, rng, home_deg=HOME).to_csv(folder / "sweeps.csv", index=False)
    register(read_sweeps(folder / "sweeps.csv"), cell, rng=0, draws=200).save(folder / "reg.json")
    # Table I's points 50 mm along axis 2, placed through the true paper frame, not the registered one.
    axes = urdf_axes(cell.robot, np.array(HOME) * DEG)
    rotation, origin = paper_frame(*axes[0], *axes[1])
    arcs = pd.read_csv(DATA / "table1_geometry.csv", comment="#")
    paper = np.column_stack([arcs.x_mm, arcs.y_mm, np.full(len(arcs), 50.0)]) * MM
    tracker = placement.to_tracker(paper @ rotation.T + origin) / MM
    arcs.assign(x_mm=tracker[:, 0], y_mm=tracker[:, 1], z_mm=tracker[:, 2]).to_csv(folder / "arcs.csv", index=False)
    arcs[["q2_deg", "marker", "x_mm", "y_mm"]].to_csv(folder / "arcs_planar.csv", index=False)
    return folder


@pytest.fixture
def run(monkeypatch, capsys):
    def call(*argv) -> tuple[int, str, str]:
        monkeypatch.setattr(cli, "COMMANDS", (argv[0],))
        status = cli.main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return status, out, err.strip()

    return call


def _identified(payload) -> dict[str, dict]:
    return {name: entry for name, entry in payload["parameters"].items() if "mean" in entry}


def _calibrate_registered(files, run) -> dict:
    """Calibrate the tracker-frame campaign with its registration, once per module (the posterior kept for the report)."""
    posterior = files / "calibration.nc"
    if not posterior.exists():
        status, out, _ = run("calibrate", files / "tracker.csv", "--config", CONFIG, "--registration", files / "reg.json",
                             "--posterior", posterior, *QUICK)
        assert status == 0
        (files / "calibration.json").write_text(out)
    return json.loads((files / "calibration.json").read_text())


def test_calibrate_in_the_tracker_frame_matches_the_base_frame(files, run):
    registered = _calibrate_registered(files, run)
    status, out, _ = run("calibrate", files / "base.csv", "--config", CONFIG, *QUICK)
    base = _identified(json.loads(out))
    assert registered["registration"]["frame"] == "base"
    assert registered["registration"]["added_over_tracker_max"] < 0.05
    shifts = [abs(entry["mean"] - base[name]["mean"]) / base[name]["sd"] for name, entry in _identified(registered).items()]
    assert len(shifts) >= 5 and max(shifts) < 0.5


def test_calibrate_of_a_tracker_frame_file_without_registration_is_refused(files, run):
    status, _, error = run("calibrate", files / "tracker.csv", "--config", CONFIG, *QUICK)
    assert status == 2 and "farther than any tool" in error and len(error.splitlines()) == 1


def test_geometry_from_tracker_frame_arcs_matches_the_paper_frame(files, run):
    options = ["--chains", "2", "--draws", "300", "--json"]
    status, out, _ = run("geometry", files / "arcs.csv", "--registration", files / "reg.json", *options)
    assert status == 0
    registered = json.loads(out)
    _, out, _ = run("geometry", DATA / "table1_geometry.csv", *options)
    paper = json.loads(out)["parameters"]
    for name in ("L", "a_x", "a_y"):
        assert abs(registered["parameters"][name]["mean"] - paper[name]["mean"]) < 0.5 * paper[name]["sd"]
    assert registered["registration"]["turn_about_z_sd_mrad"] > 0


def test_planar_arcs_with_a_registration_are_refused(files, run):
    status, _, error = run("geometry", files / "arcs_planar.csv", "--registration", files / "reg.json")
    assert status == 2 and "z_mm" in error


def test_geometry_critique_takes_the_registration(files, run):
    status, out, _ = run("critique", "--geometry", files / "arcs.csv", "--registration", files / "reg.json", "--json")
    assert status == 0 and json.loads(out)["registration"]["frame"] == "paper"


def test_review_page_shows_the_registration(files, run, tmp_path):
    before = (files / "reg.json").read_bytes()
    status, _, _ = run("report", "--registration", files / "reg.json", "-o", tmp_path / "report")
    assert status == 0 and (files / "reg.json").read_bytes() == before
    numbers = json.loads((tmp_path / "report" / "numbers.json").read_text())
    assert set(numbers["registration"]["axes"]) == {"1", "2"}
    assert set(numbers["registration"]["frames"]) == {"paper", "base"}
    assert "Tracker registration" in (tmp_path / "report" / "index.html").read_text()


def test_review_refuses_another_commands_json_as_registration(files, run, tmp_path):
    wrong = tmp_path / "critique.json"
    wrong.write_text('{"verdict": "adequate", "causes": [], "evidence": {}, "gain": {}}')
    status, _, error = run("report", "--registration", wrong, "-o", tmp_path / "report")
    assert status == 2 and "bayescal axes -o" in error and not (tmp_path / "report").exists()


def test_review_of_a_registered_calibration(files, run, tmp_path):
    _calibrate_registered(files, run)
    status, _, error = run("report", "--calibration", files / "calibration.nc", "--campaign", files / "tracker.csv",
                           "--config", CONFIG, "--registration", files / "reg.json", "-o", tmp_path / "report")
    assert status == 0, error
    numbers = json.loads((tmp_path / "report" / "numbers.json").read_text())
    assert "registration" in numbers and "parameters" in numbers
    # Without the registration the same calibration does not fit the tracker-frame campaign, and the report says so.
    status, _, error = run("report", "--calibration", files / "calibration.nc", "--campaign", files / "tracker.csv",
                           "--config", CONFIG, "-o", tmp_path / "other")
    assert status == 2 and len(error.splitlines()) == 1
