"""``plan --order passes`` and ``--drift-from-repeats``: a drift measured from a campaign's repeats spread in time."""

import json

import numpy as np
import pandas as pd

from bayescal.cli import main
from bayescal.twin.drift import TIMELINE


def run(capsys, command, argv):
    status = main([command, *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_a_plan_in_passes_is_simulated_in_passes_and_its_repeats_measure_the_drift(capsys, data_dir, tmp_path):
    plan, campaign = tmp_path / "plan.csv", tmp_path / "campaign.csv"
    config = str(data_dir / "kr270.toml")
    status, out, _ = run(capsys, "plan", ["--config", config, "--model", "linear", "--starts", "1", "--order", "passes",
                                          "-o", str(plan), "--json"])
    assert status == 0 and json.loads(out)["order"] == "passes"
    text = plan.read_text(encoding="utf-8")
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert rows[0].endswith(",in_passes") and {row[-2:] for row in rows[1:]} == {",1"} and "--order passes" in text
    status, _, _ = run(capsys, "simulate", ["--plan", str(plan), "--config", config, "--drift", "0.6", "-o", str(campaign)])
    assert status == 0
    frame = pd.read_csv(campaign, comment="#")
    first = frame[(frame["config"] == 1)].groupby("repeat")["t0_s"].min().to_numpy()
    # a configuration's repeats a pass apart: 15 configurations of one hang, unhang and move each
    assert np.allclose(np.diff(first), 15 * (TIMELINE["hang"] + TIMELINE["unhang"] + TIMELINE["move"]))
    status, out, _ = run(capsys, "calibrate", [str(campaign), "--config", config, "--drift-from-repeats", "--draws", "100", "--json"])
    assert status == 0
    drift = json.loads(out)["drift"]
    assert drift["source"] == "repeats" and drift["nests"] == 0 and drift["repeat_groups"] > 0
    # 0.6 mm/h over the 5 min a load hangs: tens of micrometres in each deflection
    assert 10 < drift["deflection_removed_rms_um"] < 200 and "file" not in drift


def test_a_plan_half_in_passes_is_one_line_and_exit_2(capsys, data_dir, tmp_path):
    plan = tmp_path / "plan.csv"
    body = [line for line in (data_dir / "table3_plan.csv").read_text(encoding="utf-8").splitlines() if not line.startswith("#")]
    plan.write_text("\n".join([body[0] + ",in_passes"] + [line + f",{k % 2}" for k, line in enumerate(body[1:])]) + "\n",
                    encoding="utf-8")
    status, _, err = run(capsys, "simulate", ["--plan", str(plan), "--config", str(data_dir / "kr270.toml"), "-o", str(tmp_path / "c.csv")])
    assert status == 2 and "in_passes" in err and "every line" in err and err.count("\n") == 1


def test_drift_from_repeats_needs_times_and_repeats_apart(capsys, data_dir, tmp_path):
    config = str(data_dir / "kr270.toml")
    untimed, once = tmp_path / "untimed.csv", tmp_path / "once.csv"
    assert run(capsys, "simulate", ["--plan", str(data_dir / "table3_plan.csv"), "--config", config, "-o", str(untimed)])[0] == 0
    status, _, err = run(capsys, "calibrate", [str(untimed), "--config", config, "--drift-from-repeats"])
    assert status == 2 and "--drift-from-repeats" in err and "t0_s, t1_s" in err and err.count("\n") == 1
    assert run(capsys, "simulate", ["--plan", str(data_dir / "table3_plan.csv"), "--config", config, "--repeats", "1",
                                    "--order", "passes", "-o", str(once)])[0] == 0
    status, _, err = run(capsys, "critique", [str(once), "--config", config, "--drift-from-repeats"])
    assert status == 2 and "read twice" in err and err.count("\n") == 1
