"""Tests of ``bayescal compensate``."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

import bayescal.cli as cli
from bayescal_studies.studies.compensation import random_program


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("compensate",))
    return cli.main


@pytest.fixture
def program_csv(cell, tmp_path):
    path = tmp_path / "program.csv"
    table = random_program(cell, 12, np.random.default_rng(0)).table
    table.insert(0, "op", [f"N{10 * (i + 1)}" for i in range(len(table))])
    path.write_text("# a milling pass\n" + table.to_csv(index=False))
    return path


def _run(main, program, calibration, config, out, *extra):
    return main(["compensate", str(program), "--calibration", str(calibration), "--config", str(config), "-o", str(out), *extra])


def test_writes_the_compensated_program_and_its_summary(main, short_calibration, program_csv, tmp_path, capsys):
    out = tmp_path / "compensated.csv"
    before = program_csv.read_bytes()
    assert _run(main, program_csv, short_calibration["calibration"], short_calibration["config"], out, "--json", "--tolerance-mm", "0.05") == 0
    payload = json.loads(capsys.readouterr().out)
    assert program_csv.read_bytes() == before
    table = pd.read_csv(out)
    assert list(table.columns[:7]) == ["op", "q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg"]
    for name in ["q1_cmd_deg", "q6_cmd_deg", "deflection_mm", "error_rms_mm", "error_q95_mm", "error_q9973_mm", "flag"]:
        assert name in table.columns
    assert table["op"].iloc[0] == "N10"
    assert (table["error_rms_mm"] < table["error_q95_mm"]).all() and (table["error_q95_mm"] < table["error_q9973_mm"]).all()
    assert 0.1 < table["deflection_mm"].median() < 10
    summary = payload["summary"]
    assert summary["poses"] == 12 and "k1" in summary["unidentified"]
    flagged = table["flag"] != "ok"
    assert summary["flagged"] == flagged.sum()
    assert (table.loc[flagged, "error_q9973_mm"] > 0.05).all() and (table.loc[~flagged, "error_q9973_mm"] <= 0.05).all()
    assert table.loc[flagged, "flag"].str.contains("above the tolerance").all()


def test_a_target_outside_the_joint_limits_is_flagged_not_clipped(main, cell, short_calibration, tmp_path):
    program = tmp_path / "edge.csv"
    upper = np.degrees(cell.robot.upper)
    q = [0.0, -50.0, 80.0, 0.0, -30.0, float(upper[5])]
    # A twisting moment about the flange axis turns joint 6 beyond its upper limit: the compensation must go further.
    rotation, _ = cell.robot.flange_pose(np.radians(q))
    moment = -300.0 * rotation[:, 2] * np.sign(cell.robot.flange_jacobian(np.radians(q))[5, 5])
    row = ",".join(f"{v:.9g}" for v in [*q, 0.0, 0.0, 0.0, *moment])
    program.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm\n" + row + "\n")
    out = tmp_path / "out.csv"
    assert _run(main, program, short_calibration["calibration"], short_calibration["config"], out) == 0
    table = pd.read_csv(out)
    assert "outside the limits" in table["flag"].iloc[0]
    assert table["q6_cmd_deg"].iloc[0] > upper[5]


@pytest.mark.parametrize(
    "row, column",
    [
        ("0,-50,80,0,-30,400,0,0,-500,0,0,0", "q6_deg"),
        ("0,-50,80,0,-30,0,0,0,-9e6,0,0,0", "fz_N"),
        ("0,-50,80,0,-30,0,0,0,-500,0,0,5e6", "mz_Nm"),
        ("0,-50,80,0,-30,0,0,0,abc,0,0,0", "fz_N"),
    ],
)
def test_bad_rows_exit_2_naming_line_and_column(main, short_calibration, tmp_path, capsys, row, column):
    program = tmp_path / "bad.csv"
    program.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm\n" + row + "\n")
    assert _run(main, program, short_calibration["calibration"], short_calibration["config"], tmp_path / "o.csv") == 2
    error = capsys.readouterr().err
    assert f"{program}:2" in error and column in error and "Traceback" not in error
    assert not (tmp_path / "o.csv").exists()


def test_a_calibration_of_another_cell_is_refused(main, short_calibration, program_csv, tmp_path, capsys):
    import xarray as xr

    from bayescal.sampling.summary import load, save

    tree = load(short_calibration["calibration"])
    posterior = tree["posterior"].to_dataset()
    posterior["k7"] = posterior["k6"]
    other = xr.DataTree.from_dict({"posterior": posterior})
    other.attrs.update(tree.attrs | {"n_joints": 7})
    save(other, tmp_path / "seven.nc")
    assert _run(main, program_csv, tmp_path / "seven.nc", short_calibration["config"], tmp_path / "o.csv") == 2
    assert "7 joints" in capsys.readouterr().err
    assert _run(main, program_csv, short_calibration["geometry"], short_calibration["config"], tmp_path / "o.csv") == 2
    assert "not an elastostatic posterior" in capsys.readouterr().err


def test_refuses_to_write_over_its_program(main, short_calibration, program_csv, capsys):
    before = program_csv.read_bytes()
    assert _run(main, program_csv, short_calibration["calibration"], short_calibration["config"], program_csv) == 2
    assert program_csv.read_bytes() == before
    assert "-o" in capsys.readouterr().err


def test_a_per_row_tool_point_needs_its_three_columns(main, short_calibration, tmp_path, capsys):
    program = tmp_path / "tcp.csv"
    program.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm,tcp_x_mm\n0,-50,80,0,-30,0,0,0,-500,0,0,0,300\n")
    assert _run(main, program, short_calibration["calibration"], short_calibration["config"], tmp_path / "o.csv") == 2
    assert "tcp_y_mm" in capsys.readouterr().err


def test_the_terminal_gets_a_summary_and_the_controller_fixed_decimals(main, short_calibration, program_csv, tmp_path, capsys):
    out = tmp_path / "compensated.csv"
    assert _run(main, program_csv, short_calibration["calibration"], short_calibration["config"], out, "--decimals", "3") == 0
    text = capsys.readouterr().out
    assert "12 poses compensated" in text and "worst" in text and "flagged:" in text and "{" not in text
    written = out.read_text().splitlines()
    header = written[0].split(",")
    column = header.index("q1_cmd_deg")
    for line in written[1:]:
        value = line.split(",")[column]
        # "12.345", never "1.2e-05" nor "-0.000"
        assert "e" not in value.lower() and value != "-0.000" and len(value.split(".")[1]) == 3
