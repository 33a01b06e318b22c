"""``--nests`` on calibrate and critique: the drift the reference nests measure, removed and reported."""

import json

import numpy as np
import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cli import main
from bayescal.sampling.summary import load
from bayescal.twin.independent.generator import IndependentGenerator


@pytest.fixture(scope="module")
def files(cell, plan, data_dir, tmp_path_factory):
    folder = tmp_path_factory.mktemp("nests")
    campaign, truth = IndependentGenerator(cell, np.random.default_rng(4), truth="config").simulate(
        plan, 3, "thermal_drift", 3.0, nests=True
    )
    paths = {"campaign": folder / "campaign.csv", "nests": folder / "nests.csv", "untimed": folder / "untimed.csv",
             "config": str(data_dir / "kr270.toml")}
    write_campaign(campaign, paths["campaign"], comments=["independent generator, thermal_drift x3, seed 4"])
    truth.nests.write(paths["nests"], ("independent generator's nests, seed 4",))
    frame = campaign.to_frame().drop(columns=["t0_s", "t1_s"])
    paths["untimed"].write_text(frame.to_csv(index=False), encoding="utf-8")
    return paths


def run(capsys, command, argv):
    status = main([command, *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_calibrate_removes_the_drift_and_says_how_much(capsys, files):
    argv = [str(files["campaign"]), "--config", files["config"], "--nests", str(files["nests"]), "--draws", "100"]
    status, out, _ = run(capsys, "calibrate", [*argv, "--json"])
    assert status == 0
    drift = json.loads(out)["drift"]
    assert drift["file"] == str(files["nests"]) and drift["nests"] == 3
    # a 0.6 mm/h drift over the 8 min a load takes to hang: tens of micrometres in each deflection
    assert 20 < drift["deflection_removed_rms_um"] < 200 and drift["deflection_sd_added_median_um"] > 0
    status, out, _ = run(capsys, "calibrate", argv)
    assert status == 0 and "drift from 3 reference nests" in out and "μm rms" in out


def test_calibrate_integrates_over_the_drifts_draws_and_says_how_many(capsys, files):
    argv = [str(files["campaign"]), "--config", files["config"], "--nests", str(files["nests"]), "--draws", "100"]
    status, out, _ = run(capsys, "calibrate", [*argv, "--drift-draws", "3", "--json"])
    payload = json.loads(out)
    # one calibration per draw, each fit's chains kept as chains
    assert status == 0 and payload["drift"]["draws_integrated"] == 3 and payload["diagnostics"]["n_chains"] == 3 * 32
    status, out, _ = run(capsys, "calibrate", argv)
    assert status == 0 and "integrated over: one calibration per draw of the drift (8 draws), pooled" in out
    status, _, err = run(capsys, "calibrate", [*argv, "--drift-draws", "1"])
    assert status == 2 and "--drift-draws" in err and "a whole number >= 2" in err
    # without a drift measured the option has nothing to integrate over
    status, _, err = run(capsys, "calibrate", [str(files["campaign"]), "--config", files["config"], "--drift-draws", "4"])
    assert status == 2 and err.startswith("bayescal calibrate: error: --drift-draws: expected with --nests") and err.count("\n") == 1


def test_critique_measures_the_drift_instead_of_trying_it(capsys, files):
    status, out, _ = run(capsys, "critique", [str(files["campaign"]), "--config", files["config"], "--nests", str(files["nests"]), "--json"])
    assert status == 0
    payload = json.loads(out)
    assert payload["drift"]["source"] == "reference nests" and payload["drift"]["candidate"] is False
    assert "drift" not in payload["causes"] and "drift" not in payload["evidence"]


@pytest.mark.parametrize("command", ["calibrate", "critique"])
def test_nests_need_the_campaigns_times(capsys, files, command):
    status, _, err = run(capsys, command, [str(files["untimed"]), "--config", files["config"], "--nests", str(files["nests"])])
    assert status == 2 and err.count("\n") == 1
    assert "untimed.csv" in err and "t0_s, t1_s" in err


def test_a_bad_nests_file_is_one_line_and_exit_2(capsys, files, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("nest,t_s,x_mm,y_mm\nN1,0,1,2\n", encoding="utf-8")
    status, _, err = run(capsys, "calibrate", [str(files["campaign"]), "--config", files["config"], "--nests", str(bad)])
    assert status == 2 and err.count("\n") == 1 and "bad.csv" in err and "z_mm" in err


def test_the_nests_file_is_never_overwritten(capsys, files):
    before = files["nests"].read_bytes()
    status, _, err = run(capsys, "calibrate", [str(files["campaign"]), "--config", files["config"], "--nests", str(files["nests"]),
                                               "--posterior", str(files["nests"])])
    assert status == 2 and "--posterior" in err and files["nests"].read_bytes() == before


def test_simulate_writes_a_timed_twin_campaign_and_its_nests(capsys, data_dir, tmp_path):
    campaign, nests = tmp_path / "campaign.csv", tmp_path / "nests.csv"
    argv = ["--plan", str(data_dir / "table3_plan.csv"), "--config", str(data_dir / "kr270.toml"), "--drift", "0.4",
            "--nests", str(nests), "-o", str(campaign), "--json"]
    status, out, _ = run(capsys, "simulate", argv)
    assert status == 0
    payload = json.loads(out)
    assert payload["drift_mm_per_h"] == 0.4 and payload["nests"]["readings"] == 3 * (1 + 2 * 15 * 3)
    assert "t0_s" in campaign.read_text(encoding="utf-8") and nests.read_text(encoding="utf-8").count("\nR1,") == 91
    status, out, _ = run(capsys, "critique", [str(campaign), "--config", str(data_dir / "kr270.toml"), "--nests", str(nests), "--json"])
    assert status == 0 and json.loads(out)["drift"]["source"] == "reference nests"


def test_simulate_refuses_to_write_the_nests_over_the_campaign(capsys, data_dir, tmp_path):
    same = str(tmp_path / "campaign.csv")
    status, _, err = run(capsys, "simulate", ["--plan", str(data_dir / "table3_plan.csv"), "--config", str(data_dir / "kr270.toml"),
                                              "--nests", same, "-o", same])
    assert status == 2 and "--nests" in err and err.count("\n") == 1


def test_plan_says_where_to_read_the_nests_and_simulate_reads_them_there(capsys, data_dir, tmp_path):
    plan, nests = tmp_path / "plan.csv", tmp_path / "nests.csv"
    config = str(data_dir / "kr270.toml")
    status, _, _ = run(capsys, "plan", ["--config", config, "--model", "linear", "--starts", "1", "--nests", "3", "-o", str(plan)])
    assert status == 0
    rows = [line for line in plan.read_text(encoding="utf-8").splitlines() if not line.startswith("#")]
    assert rows[0].endswith(",read_nests") and [row[-1] for row in rows[1:]] == list("100" * 5)
    status, _, _ = run(capsys, "simulate", ["--plan", str(plan), "--config", config, "--nests", str(nests), "-o", str(tmp_path / "c.csv")])
    assert status == 0
    # a visit before the campaign, and two per repeat at the five marked configurations
    assert nests.read_text(encoding="utf-8").count("\nR2,") == 1 + 2 * 3 * 5


def test_a_bad_read_nests_value_is_one_line_and_exit_2(capsys, data_dir, tmp_path):
    plan = tmp_path / "plan.csv"
    lines = (data_dir / "table3_plan.csv").read_text(encoding="utf-8").splitlines()
    body = [line for line in lines if not line.startswith("#")]
    plan.write_text("\n".join([body[0] + ",read_nests"] + [line + ",2" for line in body[1:]]) + "\n", encoding="utf-8")
    status, _, err = run(capsys, "simulate", ["--plan", str(plan), "--config", str(data_dir / "kr270.toml"), "--nests",
                                              str(tmp_path / "n.csv"), "-o", str(tmp_path / "c.csv")])
    assert status == 2 and "read_nests" in err and "expected 1" in err and err.count("\n") == 1


def test_report_removes_the_drift_from_the_campaign_it_checks_the_calibration_against(capsys, files, tmp_path):
    posterior = tmp_path / "posterior.nc"
    common = ["--config", files["config"], "--nests", str(files["nests"])]
    status, out, _ = run(capsys, "calibrate", [str(files["campaign"]), *common, "--draws", "100", "--posterior", str(posterior), "--json"])
    assert status == 0
    calibrated = json.loads(out)
    # the posterior file records the drift taken out of the campaign it was fitted to, and over how many draws
    assert json.loads(load(posterior).attrs["nest_drift"])["nests"] == 3
    assert json.loads(load(posterior).attrs["nest_drift"])["draws_integrated"] == 8
    status, out, _ = run(capsys, "report", ["--calibration", str(posterior), "--campaign", str(files["campaign"]), *common,
                                            "-o", str(tmp_path / "review")])
    assert status == 0 and (tmp_path / "review" / "index.html").is_file()
    # the pooled draws restored on the campaign the drift's mean was taken out of: the numbers calibrate gave
    numbers = json.loads((tmp_path / "review" / "numbers.json").read_text(encoding="utf-8"))
    assert numbers["parameters"]["parameters"]["k3"]["mean"] == calibrated["parameters"]["k3"]["mean"]
    assert numbers["residuals"]["chi2_per_dof"] == calibrated["diagnostics"]["chi2_per_dof"]
    assert numbers["overview"]["elastostatic_diagnostics"]["r_hat_max"] == calibrated["diagnostics"]["r_hat_max"]
    status, _, err = run(capsys, "report", ["--calibration", str(posterior), "--nests", str(files["nests"]), "-o", str(tmp_path / "r2")])
    assert status == 2 and err.count("\n") == 1


def test_simulate_in_passes_makes_the_drift_testable_from_the_repeats(capsys, data_dir, tmp_path):
    campaign = tmp_path / "campaign.csv"
    config = str(data_dir / "kr270.toml")
    argv = ["--plan", str(data_dir / "table3_plan.csv"), "--config", config, "--drift", "0.4", "--order", "passes", "-o", str(campaign)]
    assert run(capsys, "simulate", argv)[0] == 0
    status, out, _ = run(capsys, "critique", [str(campaign), "--config", config, "--json"])
    # a configuration's repeats 2.25 h apart (15 configurations of 9 min): the drift is testable without nests
    assert status == 0 and json.loads(out)["drift"]["testable"] is True


def test_nests_on_another_clock_are_refused(capsys, files, tmp_path):
    shifted = tmp_path / "shifted.csv"
    lines = files["nests"].read_text(encoding="utf-8").splitlines()
    out = [line if line.startswith("#") or line.startswith("nest,") else
           ",".join([line.split(",")[0], str(float(line.split(",")[1]) + 1e6), *line.split(",")[2:]]) for line in lines]
    shifted.write_text("\n".join(out) + "\n", encoding="utf-8")
    status, _, err = run(capsys, "calibrate", [str(files["campaign"]), "--config", files["config"], "--nests", str(shifted)])
    assert status == 2 and err.count("\n") == 1 and "shifted.csv" in err and "one clock" in err
