"""Tests of ``bayescal plan``."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from bayescal.numbers import error_length

import bayescal.cli as cli
from bayescal.cell.plan import read_plan
from bayescal.cell.config import load_cell

DATA = Path(__file__).resolve().parents[2] / "data"

PLAN, CONFIG = str(DATA / "table3_plan.csv"), str(DATA / "kr270.toml")


@pytest.fixture
def main(monkeypatch):
    # only this subcommand: the test does not depend on the others being importable
    monkeypatch.setattr(cli, "COMMANDS", ("plan",))
    return cli.main


def test_evaluates_table_iii(main, capsys):
    assert main(["plan", "--config", CONFIG, "--evaluate", PLAN, "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    # mm: micrometres from the data, and k1's prior (hanging loads cannot identify it) on top: 0.6 mm in all,
    # the test pose's budget of `bayescal calibrate` on a Table III campaign (0.63 mm rms).
    assert 0.001 < payload["criterion_identified_only"] < 0.05 and 0.3 < payload["criterion"] < 1.0
    assert payload["criterion_prior_share_of_mean_square"] > 0.99 and "k1" in payload["criterion_includes"]
    assert payload["parameters"]["k1"]["width_3sd_pct"] is None
    assert 0.5 < payload["parameters"]["k2"]["width_3sd_pct"] < 5
    assert payload["parameters"]["K_c"]["width_3sd_pct"] > 100  # not identifiable (README)
    assert payload["linear_model"]["criterion"] > 0 and payload["configurations"] == 15
    assert all(set(v) == {"config", "reason"} for v in payload["violations"])
    assert main(["plan", "--config", CONFIG, "--evaluate", PLAN]) == 0
    out = capsys.readouterr().out
    # ρ0 in μm; widths rounded to two digits of their 3 sd; the cell's hanging-only limit said once
    assert f"everything counted: {error_length(payload['criterion'])}" in out
    assert f"from the plan's data alone {error_length(payload['criterion_identified_only'])}" in out
    k4 = payload["parameters"]["k4"]
    assert f"{k4['width_3sd']:.2g}" in out.split("\nk4 ")[1].splitlines()[0]
    assert out.count("hangs masses only") == 1


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--angles", "40"], "--angles: 40 q2 angles do not fit in the joint range"),
        (["--angles", "2"], "at least 3 distinct q2 angles"),
        (["--mass-kg", "0", "0"], "--mass-kg: expected masses above 0 kg"),
        (["--mass-kg", "280", "250"], "--mass-kg: expected the lighter mass first"),
        (["--per-angle", "21"], "--per-angle: expected at most 20 configurations per q2 angle"),
        (["--starts", "0"], "argument --starts: expected a whole number >= 1"),
        (["--workers", "0"], "argument --workers: expected a whole number >= 1"),
        (["--workers", "2", "--evaluate", str(DATA / "table3_plan.csv")], "--workers: --workers shares out a design's starts"),
        (["--workers", "2", "--criterion", "discriminate", "--between", "backlash,outliers", "--campaign", "c.csv"], "--workers: --workers shares out the exchange's"),
    ],
)
def test_infeasible_requests_exit_2_with_one_line(main, tmp_path, capsys, options, message):
    assert main(["plan", "--config", CONFIG, "-o", str(tmp_path / "plan.csv")] + options) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and err.startswith("bayescal plan: error:")
    assert not (tmp_path / "plan.csv").exists()


def test_a_test_pose_outside_the_joint_limits_exits_2(main, tmp_path, capsys):
    text = (DATA / "kr270.toml").read_text().replace("q_deg = [0.0, -50.0, 80.0", "q_deg = [0.0, 50.0, 80.0")
    (tmp_path / "robots").symlink_to(DATA / "robots")
    (tmp_path / "cell.toml").write_text(text)
    assert main(["plan", "--config", str(tmp_path / "cell.toml"), "-o", str(tmp_path / "plan.csv")]) == 2
    assert "outside its limits" in capsys.readouterr().err


@pytest.mark.slow
def test_writes_a_plan_that_reads_back(main, tmp_path, capsys):
    out = tmp_path / "plan.csv"
    args = ["plan", "--config", CONFIG, "--angles", "4", "--per-angle", "2", "--model", "linear", "--starts", "1", "-o", str(out), "--json"]
    assert main(args) == 0
    payload = json.loads(capsys.readouterr().out)
    plan = read_plan(out, load_cell(CONFIG).robot)
    assert len(plan) == 8 and payload["configurations"] == 8 and payload["criterion"] > 0
    first = out.read_bytes()
    assert main(args) == 0
    assert out.read_bytes() == first  # the same seed gives the same plan


def test_the_plan_file_records_every_option_that_shapes_it():
    import argparse

    from bayescal.cli.plan import _command

    args = argparse.Namespace(
        config="cell.toml", angles=10, per_angle=3, repeats=2, criterion="compensator", model="linear", seed=4, mass_kg=[250.0, 280.0],
        nests=2, order="passes",
    )
    assert _command(args, 3) == (
        "bayescal plan --config cell.toml --angles 10 --per-angle 3 --repeats 2 --criterion compensator --model linear "
        "--starts 3 --seed 4 --mass-kg 250 280 --nests 2 --order passes"
    )


def test_an_any_direction_cell_gets_force_columns_and_evaluates_them(main, tmp_path, capsys):
    config = str(DATA / "kr270_any_load.toml")
    output = tmp_path / "plan.csv"
    options = ["--angles", "3", "--per-angle", "2", "--model", "linear", "--starts", "1", "--seed", "2"]
    assert main(["plan", "--config", config, "-o", str(output)] + options) == 0
    assert "forces of 2750 N in directions of the design" in capsys.readouterr().out
    header = [line for line in output.read_text().splitlines() if not line.startswith("#")][0]
    assert header.endswith("fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm") and "load_kg" not in header
    assert main(["plan", "--config", config, "--evaluate", str(output), "--json"]) == 0
    evaluated = json.loads(capsys.readouterr().out)
    assert evaluated["violations"] == [] and evaluated["parameters"]["k1"]["excited"]
    assert evaluated["parameters"]["k1"]["width_3sd_pct"] is not None
    # the same plan on a cell that can only hang masses is refused when read
    assert main(["plan", "--config", CONFIG, "--evaluate", str(output)]) == 2
    err = capsys.readouterr().err.strip()
    assert "not straight down" in err or "applies none" in err
    assert "\n" not in err


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--criterion", "discriminate", "--between", "backlash,gremlins", "--campaign", PLAN], "--between: unknown candidate 'gremlins'"),
        (["--criterion", "discriminate", "--between", "backlash,backlash", "--campaign", PLAN], "--between: expected two different candidates"),
        (["--criterion", "discriminate", "--between", "backlash,nonlinear_stiffness"], "go together with --criterion discriminate"),
        (["--between", "backlash,nonlinear_stiffness", "--campaign", PLAN], "go together with --criterion discriminate"),
    ],
)
def test_a_discriminating_request_without_its_pair_or_campaign_exits_2_with_one_line(main, tmp_path, capsys, options, message, twin_campaign):
    if "--campaign" in options:
        from bayescal.cell.campaign import write_campaign

        campaign = tmp_path / "tie.csv"
        write_campaign(twin_campaign(("backlash=0.002",), seed=0), campaign)
        options = [str(campaign) if value == PLAN else value for value in options]
    assert main(["plan", "--config", CONFIG, "-o", str(tmp_path / "plan.csv")] + options) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and err.startswith("bayescal plan: error:")
    assert not (tmp_path / "plan.csv").exists()


def test_on_a_terminal_the_design_says_how_long_it_will_take(main, tmp_path, capsys, monkeypatch):
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    options = ["--angles", "3", "--per-angle", "1", "--model", "linear", "--starts", "1"]
    assert main(["plan", "--config", CONFIG, "-o", str(tmp_path / "plan.csv")] + options) == 0
    err = capsys.readouterr().err
    assert "bayescal plan: designing 3 × 1 configurations with the linear model, about 1 s" in err
    assert re.search(r"best: ρ0 = [\d.]+ μm", err)  # the progress line gives the criterion in its unit


def test_designing_a_plan_does_not_load_pandas(tmp_path, modules_loaded_by):
    # pandas takes 0.15 s of the linear design's second of start-up and search; the design reads no table
    arguments = ["plan", "--config", CONFIG, "--model", "linear", "--angles", "3", "--per-angle", "1", "--starts", "1",
                 "-o", tmp_path / "plan.csv"]
    assert modules_loaded_by(arguments, ("pandas",)) == []
