"""Tests of ``bayescal simulate``."""

from __future__ import annotations

import json
import re
import shutil

import pytest

import bayescal.cli as cli
from bayescal.cell.campaign import read_campaign


@pytest.fixture
def plan_csv(data_dir):
    return str(data_dir / "table3_plan.csv")


@pytest.fixture
def config_toml(data_dir):
    return str(data_dir / "kr270.toml")


@pytest.fixture
def main(monkeypatch):
    # only this subcommand: the test does not depend on the others being importable
    monkeypatch.setattr(cli, "COMMANDS", ("simulate",))
    return cli.main


def test_writes_the_table_iii_campaign(main, tmp_path, capsys, config_toml, plan_csv):
    out = tmp_path / "campaign.csv"
    args = ["simulate", "--plan", plan_csv, "--config", config_toml, "--repeats", "3", "--seed", "1", "-o", str(out)]
    assert main(args + ["--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["rows"] == 135 and payload["equations"] == 405 and payload["configurations"] == 15
    assert payload["compensator"] is True and payload["effects"] == []
    assert 20 < payload["noise_sd_um"]["min"] < payload["noise_sd_um"]["max"] < 60
    assert 3 < payload["max_deflection_mm"] < 20
    campaign = read_campaign(out, markers=["M1", "M2", "M3"])
    assert campaign.n_equations == 405
    first = out.read_bytes()
    assert main(args) == 0
    assert "405 equations" in capsys.readouterr().out
    assert out.read_bytes() == first


def test_effects_and_seed_change_the_file(main, tmp_path, capsys, config_toml, plan_csv):
    base = ["simulate", "--plan", plan_csv, "--config", config_toml, "--repeats", "1"]
    main(base + ["-o", str(tmp_path / "a.csv")])
    main(base + ["-o", str(tmp_path / "b.csv"), "--seed", "2"])
    capsys.readouterr()
    main(base + ["-o", str(tmp_path / "c.csv"), "--effect", "backlash=0.02", "--effect", "compensator=0", "--json"])
    payload = json.loads(capsys.readouterr().out)
    assert payload["compensator"] is False
    assert payload["effects"] == [
        {"name": "compensator", "magnitude": 0.0, "unit": "x K_c"},
        {"name": "backlash", "magnitude": 0.02, "unit": "deg"},
    ]
    texts = [(tmp_path / name).read_text() for name in ("a.csv", "b.csv", "c.csv")]
    assert texts[0] != texts[1] and texts[0] != texts[2]
    assert "backlash=0.02 deg" in texts[2] and "compensator off" in texts[2]


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--effect", "wobble"], "--effect: unknown effect 'wobble'"),
        (["--effect", "backlash", "--effect", "backlash=0.01"], "--effect: effect 'backlash' is given more than once"),
        (["--effect", "outliers=2"], "--effect: effect 'outliers' needs a fraction between 0 and 1"),
        (["--repeats", "0"], "argument --repeats: expected a whole number >= 1, got 0"),
        (["--seed", "-1"], "argument --seed: expected a whole number >= 0"),
    ],
)
def test_bad_options_exit_2(main, tmp_path, capsys, extra, message, config_toml, plan_csv):
    args = ["simulate", "--plan", plan_csv, "--config", config_toml, "-o", str(tmp_path / "x.csv")] + extra
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_plan_outside_limits_exit_2(main, tmp_path, capsys, config_toml):
    plan = tmp_path / "plan.csv"
    plan.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,-45,30,0,20,0\n0,-150,30,0,20,0\n")
    assert main(["simulate", "--plan", str(plan), "--config", config_toml, "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "plan.csv:3" in err and "q2_deg" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_missing_output_directory_exit_2(main, tmp_path, capsys, config_toml, plan_csv):
    assert main(["simulate", "--plan", plan_csv, "--config", config_toml, "-o", str(tmp_path / "no" / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "-o: the output folder" in err and "does not exist" in err


def test_a_load_the_arm_cannot_carry_exits_2_naming_the_plan_line(main, tmp_path, capsys, config_toml):
    plan = tmp_path / "plan.csv"
    plan.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,250\n0,-45,30,0,20,0,1e6\n")
    assert main(["simulate", "--plan", str(plan), "--config", config_toml, "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "plan.csv:3, column 'load_kg'" in err and "more than the 540 kg the arm can plausibly carry" in err
    assert len(err.splitlines()) == 1


def test_no_equilibrium_exits_2_naming_the_plan_line(main, tmp_path, capsys, data_dir):
    # Joints 10,000 times softer than the KR-270's: the arm folds under a load it could carry.
    shutil.copytree(data_dir / "robots", tmp_path / "robots")
    text = (data_dir / "kr270.toml").read_text()
    config = tmp_path / "soft.toml"
    config.write_text(re.sub(r"k_urad_per_Nm = \[[^]]*\]", "k_urad_per_Nm = [3000, 3020, 4060, 30020, 33030, 23650]", text))
    plan = tmp_path / "plan.csv"
    plan.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,load_kg\n0,-45,30,0,20,0,250\n0,-45,30,0,20,0,500\n")
    assert main(["simulate", "--plan", str(plan), "--config", str(config), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "plan.csv:3" in err and "no static equilibrium under 500 kg" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_help_lists_the_effects_with_their_defaults(capsys):
    assert cli.main(["simulate", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "plant an effect, repeatable: compensator:" in text
    assert "outliers: a few gross tracker errors" in text


def test_simulating_a_plan_does_not_load_pandas(tmp_path, config_toml, plan_csv, modules_loaded_by):
    # pandas takes 0.15 s of start-up; reading a plan and writing a campaign need no frame
    arguments = ["simulate", "--plan", plan_csv, "--config", config_toml, "-o", tmp_path / "campaign.csv"]
    assert modules_loaded_by(arguments, ("pandas",)) == []
