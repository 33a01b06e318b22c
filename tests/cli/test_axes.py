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
