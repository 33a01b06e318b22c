"""The KR-270 with kinematic errors from the command line: simulate, calibrate, then the absolute positions."""

from __future__ import annotations

import json

import pytest

import bayescal.cli as cli


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("simulate", "calibrate", "kinematics"))
    return cli.main


@pytest.fixture(scope="module")
def files(data_dir):
    return {"plan": str(data_dir / "table3_plan.csv"), "cell": str(data_dir / "kr270.toml"),
            "points": str(data_dir / "robots" / "kr270_points.toml")}


def test_simulate_calibrate_then_fit_the_absolute_positions(main, tmp_path, capsys, files):
    campaign, positions, posterior = tmp_path / "campaign.csv", tmp_path / "positions.csv", tmp_path / "posterior.nc"
    assert main(["simulate", "--plan", files["plan"], "--config", files["cell"], "--seed", "3", "--kinematic-errors", "1",
                 "-o", str(campaign), "--positions", str(positions), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    a2 = payload["kinematic_errors"]["joints"]["A2"]
    assert set(a2) == {"tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg"} and 0 < abs(a2["rz_deg"]) < 0.3
    assert "kinematic errors (scale 1)" in campaign.read_text() and positions.read_text().count("\n") > 45  # 15 × 3 rows
    assert main(["calibrate", str(campaign), "--config", files["cell"], "--posterior", str(posterior), "--json"]) == 0
    capsys.readouterr()
    assert main(["kinematics", str(positions), "--config", files["points"], "--elastic", str(posterior),
                 "--elastic-config", files["cell"], "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    diagnostics = result["diagnostics"]
    # Table III's 15 unloaded configurations identify the spring (the twin's K_c = 144 N/mm, s0 = 458 mm; the
    # loaded-minus-unloaded campaign leaves K_c to ±100 N/mm).
    (k, k_sd), (s0, s0_sd) = diagnostics["K_c_N_per_mm"], diagnostics["s0_mm"]
    assert abs(k - 144.0) < 3 * k_sd < 10.0 and abs(s0 - 458.0) < 3 * s0_sd
    assert diagnostics["rung"] == "geometry" and diagnostics["model_error_sd_mm"] < 0.03


def test_the_same_seed_reads_the_same_noise_with_and_without_errors(main, tmp_path, capsys, files):
    def rows(extra):
        out = tmp_path / "c.csv"
        assert main(["simulate", "--plan", files["plan"], "--config", files["cell"], "--seed", "3", "-o", str(out)] + extra) == 0
        return [line.split(",") for line in out.read_text().splitlines() if not line.startswith("#")]

    plain, erroneous = rows([]), rows(["--kinematic-errors", "1"])
    # The deflections (loaded minus unloaded) differ by microns; the positions by millimetres.
    x0, x1 = plain[0].index("x0_mm"), plain[0].index("x1_mm")
    deflection = [float(r[x1]) - float(r[x0]) for r in plain[1:]]
    moved = [float(r[x1]) - float(r[x0]) for r in erroneous[1:]]
    assert max(abs(a - b) for a, b in zip(deflection, moved)) < 0.05
    assert max(abs(float(a[x0]) - float(b[x0])) for a, b in zip(plain[1:], erroneous[1:])) > 0.5


@pytest.mark.parametrize("args, expected", [
    (["--kinematic-errors", "-1"], "--kinematic-errors: expected a plain decimal number >= 0, got '-1'"),
    (["--kinematic-errors", "1_0"], "expected a plain decimal number >= 0"),
])
def test_bad_kinematic_errors_are_named(main, tmp_path, capsys, files, args, expected):
    assert main(["simulate", "--plan", files["plan"], "--config", files["cell"], "-o", str(tmp_path / "c.csv")] + args) == 2
    assert expected in capsys.readouterr().err and not (tmp_path / "c.csv").exists()


def test_elastic_needs_its_cell_and_a_rigid_rung(main, tmp_path, capsys, files):
    positions = tmp_path / "p.csv"
    assert main(["simulate", "--plan", files["plan"], "--config", files["cell"], "-o", str(tmp_path / "c.csv"),
                 "--positions", str(positions)]) == 0
    capsys.readouterr()
    assert main(["kinematics", str(positions), "--config", files["points"], "--elastic", str(tmp_path / "x.nc")]) == 2
    assert "give --elastic and --elastic-config together" in capsys.readouterr().err
    assert main(["kinematics", str(positions), "--config", files["points"], "--elastic", str(tmp_path / "x.nc"),
                 "--elastic-config", files["cell"], "--model", "full"]) == 2
    assert "--model: with --elastic the rung is rigid" in capsys.readouterr().err
