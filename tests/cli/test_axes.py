"""Tests of ``bayescal axes``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bayescal.cli as cli
from bayescal.twin.sweeps import random_placement, simulate_sweeps
from tests.conftest import DATA

HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("axes",))
    return cli.main


@pytest.fixture
def sweeps(cell, tmp_path):
    rng = np.random.default_rng(7)
    table = simulate_sweeps(cell, random_placement(rng), rng, home_deg=HOME)
    path = tmp_path / "sweeps.csv"
    path.write_text("# joint sweeps, tracker frame\n" + table.to_csv(index=False))
    return path, table


def test_json_and_registration_file(main, sweeps, tmp_path, capsys):
    path, _ = sweeps
    before = path.read_bytes()
    out = tmp_path / "registration.json"
    assert main(["axes", str(path), "--config", str(DATA / "kr270.toml"), "--json", "-o", str(out)]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert path.read_bytes() == before
    assert json.loads(out.read_text()) == payload
    assert set(payload["axes"]) == {"1", "2"} and len(payload["axes"]["2"]["direction"]) == 3
    assert np.array(payload["frames"]["paper"]["rotation"]).shape == (3, 3)
    assert len(payload["frames"]["base"]["translation_mm"]) == 3


def test_two_joints_moving_at_once_is_exit_status_2(main, sweeps, tmp_path, capsys):
    _, table = sweeps
    table.loc[table.index[table.joint == 2][4:], "q3_deg"] += 5.0
    path = tmp_path / "coupled.csv"
    table.to_csv(path, index=False)
    assert main(["axes", str(path), "--config", str(DATA / "kr270.toml")]) == 2
    error = capsys.readouterr().err.strip()
    assert "joint 3 moves too" in error and "q3_deg" in error and len(error.splitlines()) == 1


def test_mislabelled_reflector_is_exit_status_2(main, sweeps, tmp_path, capsys):
    _, table = sweeps
    # Half of R1's readings in the joint-2 sweep are in truth R2's: that reflector no longer shares the axis.
    rows = table.index[(table.joint == 2) & (table.marker == "R2")][::2]
    table.loc[rows, "marker"] = "R1"
    path = tmp_path / "mislabelled.csv"
    table.to_csv(path, index=False)
    assert main(["axes", str(path), "--config", str(DATA / "kr270.toml")]) == 2
    assert "does not share the axis of joint 2" in capsys.readouterr().err


def _refused(main, path, capsys) -> str:
    """Run ``axes`` on ``path``; the error line, after checking exit status 2, one line and the file untouched."""
    before = path.read_bytes()
    assert main(["axes", str(path), "--config", str(DATA / "kr270.toml")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "Traceback" not in error
    assert path.read_bytes() == before
    return error


def test_fewer_than_three_angles_is_exit_status_2(main, sweeps, tmp_path, capsys):
    _, table = sweeps
    angles = sorted(table.loc[table.joint == 1, "q1_deg"].unique())
    path = tmp_path / "two_angles.csv"
    table[(table.joint != 1) | table.q1_deg.isin(angles[:2])].to_csv(path, index=False)
    error = _refused(main, path, capsys)
    assert "2 angle(s) of joint 1" in error and "q1_deg" in error and str(path) in error


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda t: t.drop(columns="z_mm"), "z_mm"),
        (lambda t: t.drop(columns="marker"), "marker"),
        (lambda t: t.assign(x_mm=t.x_mm.where(t.index != 5, np.nan)), "x_mm"),
        (lambda t: t.iloc[:0], "no data"),
        (lambda t: t.assign(x_mm=t.x_mm / 1000, y_mm=t.y_mm / 1000, z_mm=t.z_mm / 1000), "metres"),
        (lambda t: t.assign(q1_deg=np.radians(t.q1_deg), q2_deg=np.radians(t.q2_deg)), "rad"),
        (lambda t: t.assign(joint=t.joint.where(t.index != 3, 9)), "joint"),
    ],
    ids=["missing z", "missing marker", "NaN", "empty", "metres", "radians", "joint out of range"],
)
def test_bad_sweep_files_are_one_line_and_exit_status_2(main, sweeps, tmp_path, capsys, edit, expected):
    _, table = sweeps
    path = tmp_path / "bad.csv"
    edit(table.copy()).to_csv(path, index=False)
    assert expected in _refused(main, path, capsys)


def test_empty_file_is_exit_status_2(main, tmp_path, capsys):
    path = tmp_path / "empty.csv"
    path.write_text("")
    _refused(main, path, capsys)


def test_registration_that_is_not_one_is_exit_status_2(main, sweeps, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("calibrate",))
    path = tmp_path / "not_a_registration.json"
    path.write_text('{"verdict": "adequate"}')
    assert cli.main(["calibrate", str(DATA / "table3_plan.csv"), "--config", str(DATA / "kr270.toml"),
                     "--registration", str(path)]) == 2
    error = capsys.readouterr().err.strip()
    assert "bayescal axes -o" in error and len(error.splitlines()) == 1


def test_critique_flag_adds_the_sweep_critique_to_the_registration(main, sweeps, tmp_path, capsys):
    path, _ = sweeps
    out = tmp_path / "registration.json"
    assert main(["axes", str(path), "--config", str(DATA / "kr270.toml"), "--critique", "--json", "-o", str(out)]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert json.loads(out.read_text()) == payload
    critique = payload["critique"]
    assert critique["verdict"] in ("adequate", "misfit") and set(critique["joints"]) == {"1", "2"}
    assert set(critique["joints"]["2"]["evidence"]) == {"angle_scale", "transmission", "wobble", "tracker_range"}
