"""The numbers the README quotes from `make demo` are the numbers `make demo` prints."""

import json
import re
from pathlib import Path

from bayescal.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _run(capsys, argv):
    assert main(argv) == 0
    return capsys.readouterr().out


def test_the_demos_error_left_at_the_test_pose_is_the_one_the_readme_quotes(capsys, tmp_path):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    quoted = re.search(r"test pose after compensation is ([\d.]+) μm rms \(99\.73 % of draws below ([\d.]+) μm\)", readme)
    assert quoted, "the README no longer quotes the demo's error left at the test pose"
    data = ROOT / "data"
    geometry, campaign = tmp_path / "geometry.nc", tmp_path / "campaign.csv"
    # the first three steps of `make demo`, with its options and seeds
    _run(capsys, ["geometry", str(data / "table1_geometry.csv"), "--posterior", str(geometry)])
    _run(capsys, ["simulate", "--plan", str(data / "table3_plan.csv"), "--config", str(data / "kr270.toml"),
                  "--repeats", "3", "--seed", "1", "-o", str(campaign)])
    out = _run(capsys, ["calibrate", str(campaign), "--config", str(data / "kr270.toml"), "--geometry", str(geometry), "--json"])
    error = json.loads(out)["test_pose"]["residual_error_mm"]
    assert f"{error['rms'] * 1000:.1f}" == quoted.group(1)
    assert f"{error['q99.73'] * 1000:.1f}" == quoted.group(2)


def test_the_python_example_runs_and_writes_only_into_its_own_folder(tmp_path, monkeypatch):
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    code = re.search(r"```python\n(.*?)```", readme, re.S).group(1)
    assert 'out = Path("example")' in code
    # run from a folder holding only the data, so that anything written elsewhere would show
    (tmp_path / "data").symlink_to(ROOT / "data")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "example"]
    written = {p.name for p in (tmp_path / "example").iterdir()}
    assert {"geometry_posterior.nc", "calibration.nc", "program.csv", "compensated.csv", "plan.csv"} <= written
