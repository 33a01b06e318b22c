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
    assert "False alarms: of 1 campaigns without any effect, 0 % named an extension" in text


def test_a_plan_for_an_unknown_effect_is_refused(capsys):
    with pytest.raises(SystemExit) as exit:
        main(["--config", "c.toml", "--plan", "p.csv", "--plan-for", "gremlins=x.csv", "-o", "r.md"])
    assert exit.value.code == 2
    assert "expected EFFECT=PLAN.csv" in capsys.readouterr().err
