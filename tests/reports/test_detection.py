from pathlib import Path

import pytest

from bayescal.reports.detection import main, render_report

DATA = Path(__file__).resolve().parents[2] / "data"


def test_the_report_tabulates_power_thresholds_and_false_alarms():
    text = render_report(
        str(DATA / "kr270.toml"), str(DATA / "table3_plan.csv"), magnitudes={"backlash": [0.015]}, n_seeds=1, n_null=1, workers=1
    )
    assert "| backlash | 0.015 | deg | 1 | 100 % | 100 % | 100 % |" in text
    assert "- `backlash`: 0.015 deg (the twin's default: 0.015)" in text
    assert "False alarms: 0 % of 1 campaigns without any effect were called a misfit." in text


def test_a_plan_for_an_unknown_effect_is_refused(capsys):
    with pytest.raises(SystemExit) as exit:
        main(["--config", "c.toml", "--plan", "p.csv", "--plan-for", "gremlins=x.csv", "-o", "r.md"])
    assert exit.value.code == 2
    assert "expected EFFECT=PLAN.csv" in capsys.readouterr().err


def test_the_geometry_section_studies_the_geometry_critique_at_the_points_angles(monkeypatch):
    import bayescal.reports.detection as report

    monkeypatch.setattr(report, "GEOMETRY_MAGNITUDES", {"joint_scale": (0.004,)})
    lines = report._geometry_section(str(DATA / "table1_geometry.csv"), None, n_seeds=1, n_null=1, seed=0)
    text = "\n".join(lines)
    assert "at its 6 angles" in text
    assert "| none | 0 |  | 1 |" in text and "| joint_scale | 0.004 |  | 1 | 100 % |" in text
