"""Tests for bayescal/kinematics/ladder.py: the ladder's findings read back from their JSON, and their document."""

import json

import pandas as pd
import pytest

from bayescal.errors import InputError
from bayescal.kinematics.ladder import LADDER_KIND, LadderFindings


@pytest.fixture()
def findings():
    rungs = pd.DataFrame(
        [{"model": name, "mean_mm": mean, "sd_mm": 1.25, "max_mm": 9.5, "in_sample_mean_mm": mean - 0.2, "elpd": -1000.4 + i,
          "elpd_se": 20.6, "coverage_95": 0.9375, "model_error_sd_mm": 1.0} for i, (name, mean) in enumerate([("frames", 16.03), ("full", 3.40)])]
    ).set_index("model")
    without = pd.DataFrame([{"without": "k_theta", "mean_mm": 3.67, "elpd_loss": 40.0, "elpd_loss_se": 9.0}]).set_index("without")
    steps = [{"from": "frames", "to": "full", "adds": ["theta"], "elpd_gain": 900.0, "elpd_gain_se": 30.0, "error_change_mm": -12.63, "named": True}]
    return LadderFindings(rungs, steps, without, 10, "verdict: the data call for full")


def test_the_json_round_trips_through_a_file(findings, tmp_path):
    text = json.dumps(findings.to_json())
    (tmp_path / "ladder.json").write_text(text)
    loaded = LadderFindings.load(tmp_path / "ladder.json")
    assert json.dumps(loaded.to_json()) == text
    pd.testing.assert_frame_equal(loaded.rungs, findings.rungs)
    pd.testing.assert_frame_equal(loaded.without, findings.without)
    assert loaded.document().as_text() == findings.document().as_text()


def test_findings_without_a_leave_one_out_table_round_trip(findings):
    bare = LadderFindings(findings.rungs, findings.steps, pd.DataFrame(), 3, "verdict: frames")
    again = LadderFindings.from_json(json.loads(json.dumps(bare.to_json())))
    assert again.to_json() == bare.to_json() and "leave one group out" not in again.document().as_text()


def test_the_document_lays_out_rungs_steps_and_the_verdict(findings):
    lines = findings.document().as_text().splitlines()
    assert lines[0] == "model ladder, 10-fold cross-validation by configuration (held-out errors, mm; published beside):"
    assert lines[1].split() == ["model", "mean", "sd", "max", "in-sample", "ELPD", "±", "SE", "cover95", "paper", "mean/sd/max"]
    assert lines[3].split() == ["full", "3.40", "1.25", "9.50", "3.20", "-999", "21", "0.938", "3.12/1.71/8.23"]
    assert lines[5] == "  frames → full (+theta): ΔELPD +900 ± 30, mean error -12.63 mm: called for by the data"
    assert lines[7] == "  without k_theta     3.67   ΔELPD +40 ± 9   (paper 9.09)" and lines[-1] == findings.verdict
    table = findings.document().as_json()["lead"][0]
    assert table["rows"][1]["mean"] == 3.40 and table["columns"][1] == {"name": "mean", "unit": "mm"}


def test_a_file_of_another_kind_is_refused_naming_the_key(tmp_path, findings):
    path = tmp_path / "ladder.json"
    path.write_text(json.dumps({key: value for key, value in findings.to_json().items() if key != "rungs"} | {"kind": LADDER_KIND}))
    with pytest.raises(InputError, match="expected the key 'rungs'"):
        LadderFindings.load(path)
