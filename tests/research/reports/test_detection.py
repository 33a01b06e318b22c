from pathlib import Path

import pandas as pd

from bayescal_studies.reports.detection import render_report
from bayescal_studies.studies.detection import DetectionFindings

DATA = Path(__file__).resolve().parents[3] / "data"


def _findings(**changes):
    twin = pd.DataFrame(
        {"effect": ["none", "backlash"], "magnitude": [0.0, 0.015], "unit": ["", "deg"], "n": [1, 1],
         "found_first": [0.0, 1.0], "found": [0.0, 1.0], "misfit": [0.0, 1.0]}
    )
    independent = pd.DataFrame(
        {"effect": ["none", "none", "gear_play", "gear_play"], "magnitude": [0.0, 0.0, 1.0, 1.0], "seed": [9000, 9001, 9000, 9001],
         "expected": ["adequate", "adequate", "backlash", "backlash"], "verdict": ["adequate", "misfit", "misfit", "misfit"],
         "causes": ["", "unexplained", "backlash", "outliers"], "tied_with": ["", "", "", ""], "right": [True, False, True, False],
         "alone": [True, False, True, False], "wrong_single": [False, True, False, True], "lof_p": [0.5, 0.001, 0.2, 0.01],
         "classical_lof_p": [0.5, 0.001, 0.01, 0.01]}
    )
    values = dict(config="data/kr270.toml", plan="data/table3_plan.csv", twin=twin, other_plans={}, independent=independent,
                  seconds={"twin": 1.0, "independent": 2.0}, settings={"n_seeds": 1, "n_null": 1, "n_independent": 2, "repeats": 3, "seed": 0})
    return DetectionFindings(**(values | changes))


def test_the_report_renders_power_thresholds_false_alarms_and_both_generators_side_by_side():
    text = render_report(_findings())
    assert "| backlash | 0.015 | deg | 1 | 100 % | 100 % | 100 % |" in text
    assert "- `backlash`: 0.015 deg (the twin's default: 0.015)" in text
    assert "False alarms: 0 % of 1 campaigns without any effect were called a misfit." in text
    assert "| none | — | 0 % | `none` | 2 | 50 % | 50 % | 50 % | 50 % | 50 % |" in text
    assert "| backlash | 100 % | 100 % | `gear_play` | 2 | 100 % | 50 % | 50 % | 50 % | 100 % |" in text


def test_the_lack_of_fit_section_renders_size_and_power_by_multiple():
    power = pd.DataFrame(
        {"effect": ["none", "none", "thermal_drift", "thermal_drift"], "multiple": [0.0, 0.0, 1.0, 1.0],
         "seed": [9000, 9001, 9000, 9001], "statistic": [1.0, 1.2, 1.5, 1.1], "p_value": [0.5, 0.03, 0.001, 0.2],
         "dof_lof": [260] * 4, "dof_pe": [540] * 4, "null_mean": [1.01] * 4}
    )
    raised = pd.DataFrame(
        {"effect": ["thermal_drift", "thermal_drift"], "magnitude": [3.0, 1.0], "seed": [9000, 9000], "expected": ["drift", "drift"],
         "verdict": ["misfit", "adequate"], "causes": ["drift", ""], "tied_with": ["", ""], "right": [True, False],
         "alone": [True, False], "wrong_single": [False, False], "lof_p": [0.001, 0.3], "classical_lof_p": [0.001, 0.3]}
    )
    independent = pd.concat([_findings().independent, raised], ignore_index=True)
    text = render_report(
        _findings(lack_of_fit=power, independent=independent, seconds={"twin": 1.0, "independent": 2.0, "lack_of_fit": 3.0})
    )
    assert "| drift | — | — | `thermal_drift` × 3 | 1 | 100 % | 100 % | 100 % | 0 % | 100 % |" in text
    assert "| drift | — | — | `thermal_drift` | 1 | 0 % | 0 % | 0 % | 0 % | 0 % |" in text
    assert "| none | — | 2 | 50.0 % | 0.0 % | 1.100 (1.010) |" in text
    assert "| thermal_drift | 1 | 2 | 50.0 % | 50.0 % | 1.300 (1.010) |" in text
    assert "Size: 1 of 2 campaigns without an effect rejected at 5 % (a true 5 % gives 0.1 ± 0.3)." in text


def test_the_geometry_section_renders_the_geometry_critique_at_the_points_angles():
    table = pd.DataFrame(
        {"effect": ["none", "joint_scale"], "magnitude": [0.0, 0.004], "unit": ["", ""], "campaigns": [1, 1],
         "first_cause": [0.0, 1.0], "named": [0.0, 1.0], "misfit": [0.0, 1.0], "unexplained": [0.0, 0.0]}
    )
    findings = _findings(geometry=table, geometry_points=str(DATA / "table1_geometry.csv"), geometry_angles=6,
                         seconds={"twin": 1.0, "independent": 2.0, "geometry": 3.0})
    text = render_report(findings)
    assert "at its 6 angles" in text
    assert "| none | 0 |  | 1 |" in text and "| joint_scale | 0.004 |  | 1 | 100 % |" in text


def test_paper_reports_compute_the_detection_findings_from_the_paper_data_and_write_their_rendering(tmp_path, monkeypatch):
    from bayescal_studies.cli import main
    from bayescal_studies.studies import detection
    from bayescal_studies.studies.paper_reports import DETECTION_MAGNITUDES, GEOMETRY_DETECTION_MAGNITUDES, PAPER_SEEDS

    calls = []

    def findings(config, plan, magnitudes, **options):
        # An hour of campaigns stands in for a table of one campaign per effect: the command's wiring is under test.
        calls.append((config, plan, magnitudes, options))
        return _findings()

    monkeypatch.setattr(detection, "detection_findings", findings)
    out = tmp_path / "reports"
    assert main(["reports", str(out), "--paper-data", str(DATA), "--only", "detection", "--json"]) == 0
    assert (out / "detection.md").read_text(encoding="utf-8") == render_report(_findings())
    ((config, plan, magnitudes, options),) = calls
    assert (config, plan) == (str(DATA / "kr270.toml"), str(DATA / "table3_plan.csv"))
    assert magnitudes == DETECTION_MAGNITUDES and options["geometry_magnitudes"] == GEOMETRY_DETECTION_MAGNITUDES
    assert options["other_plans"] == {"compensator": str(DATA / "compensator_plan.csv")}
    assert options["geometry_points"] == str(DATA / "table1_geometry.csv") and options["seed"] == PAPER_SEEDS["detection"]
