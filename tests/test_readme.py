"""The numbers the README and its pages quote from `make demo` are the numbers `make demo` prints, and every option is documented."""

import argparse
import contextlib
import io
import json
import re
from pathlib import Path

import pytest

from bayescal.cli import build_parser, main
from bayescal_studies.cli import build_parser as build_research_parser
from bayescal.numbers import with_uncertainty

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
RESULTS = (ROOT / "docs" / "results.md").read_text(encoding="utf-8")
SPEED = (ROOT / "docs" / "speed.md").read_text(encoding="utf-8")
PYTHON = (ROOT / "docs" / "python.md").read_text(encoding="utf-8")
README_LINES = 150
"""The README is read in five minutes: the rest lives in docs/."""


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """The JSON of the first three steps of `make demo`, with its options and seeds, and calibrate's text."""
    folder = tmp_path_factory.mktemp("demo")
    data = ROOT / "data"
    geometry, campaign = folder / "geometry.nc", folder / "campaign.csv"
    outputs = {}

    def run(name, argv):
        # capsys is function-scoped: a module's fixture reads the command's output itself
        buffer, errors = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(errors):
            assert main(argv) == 0, errors.getvalue()
        outputs[name] = buffer.getvalue()

    run("geometry", ["geometry", str(data / "table1_geometry.csv"), "--posterior", str(geometry), "--json"])
    run("simulate", ["simulate", "--plan", str(data / "table3_plan.csv"), "--config", str(data / "kr270.toml"),
                     "--repeats", "3", "--seed", "1", "-o", str(campaign)])
    argv = ["calibrate", str(campaign), "--config", str(data / "kr270.toml"), "--geometry", str(geometry)]
    run("calibrate", argv + ["--json", "--posterior", str(folder / "calibration.nc")])
    run("calibrate_text", argv)
    # The one-pose program of docs/python.md: the test pose and its wrench, the moment taken about the tool point.
    (folder / "program.csv").write_text(
        "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm\n0.0,-50.0,80.0,0.0,-30.0,0.0,-1000.0,500.0,-600.0,0.0,0.0,0.0\n"
    )
    run("compensate", ["compensate", str(folder / "program.csv"), "--calibration", str(folder / "calibration.nc"),
                       "--config", str(data / "kr270.toml"), "-o", str(folder / "compensated.csv")])
    outputs["compensated"] = (folder / "compensated.csv").read_text()
    return {name: (json.loads(text) if name in ("geometry", "calibrate") else text) for name, text in outputs.items()}


def test_the_demos_error_left_at_the_test_pose_is_the_one_the_readme_quotes(demo):
    quoted = re.search(
        r"test pose after compensation, everything counted, is ([\d.]+) mm rms \(99\.73 % of draws\s+below ([\d.]+) mm\).*?"
        r"from the identified parameters alone\s+it is ([\d.]+) μm rms \(99\.73 % below ([\d.]+) μm\)",
        README,
        re.S,
    )
    assert quoted, "the README no longer quotes the demo's error left at the test pose"
    error = demo["calibrate"]["test_pose"]["residual_error_mm"]
    assert f"{error['rms']:.3f}" == quoted.group(1) and f"{error['q99.73']:.3f}" == quoted.group(2)
    identified = error["identified_only"]
    assert f"{identified['rms'] * 1000:.1f}" == quoted.group(3) and f"{identified['q99.73'] * 1000:.1f}" == quoted.group(4)
    # calibrate's text prints the same, and so does compensate on that one-pose program, with the same targets
    text = demo["calibrate_text"]
    assert f"99.73% {quoted.group(2)} mm" in text and f"99.73% {quoted.group(4)} μm" in text
    header, row = demo["compensated"].splitlines()
    written = dict(zip(header.split(","), row.split(",")))
    assert f"{float(written['error_q9973_mm']):.3f}" == quoted.group(2)
    assert f"{float(written['error_q9973_identified_mm']) * 1000:.0f}" == f"{float(quoted.group(4)):.0f}"
    targets = demo["calibrate"]["test_pose"]["joints"]
    for j in range(1, 7):
        assert written[f"q{j}_cmd_deg"] == f"{round(targets[f'q{j}']['compensated_deg'], 4) + 0.0:.4f}"


def test_the_geometry_the_readme_quotes_is_the_demos(demo):
    parameters = demo["geometry"]["parameters"]
    for name in ("L", "a_x", "a_y"):
        shown = with_uncertainty(parameters[name]["mean"], parameters[name]["sd"], "mm")
        assert f"{name} = {shown}" in RESULTS, f"docs/results.md does not quote {name} = {shown}"
    assert f"{parameters['a_y']['mean'] - 120.30:.2f}".replace("-", "−") + " mm" in RESULTS
    assert f"R-hat ≤ {demo['geometry']['diagnostics']['r_hat_max']:.3f} with the default seed" in RESULTS


def test_the_elastostatic_widths_and_diagnostics_the_readme_quotes_are_the_demos(demo):
    parameters = demo["calibrate"]["parameters"]
    widths = [300 * parameters[k]["sd"] / parameters[k]["mean"] for k in ("k2", "k3", "k4", "k5")]
    assert f"k2..k5 come\nout with ±3σ widths of {min(widths):.1f}–{max(widths):.1f} %" in README
    assert f"k6 {300 * parameters['k6']['sd'] / parameters['k6']['mean']:.1f} %" in README
    change = re.search(r"by ([\d.]+–[\d.]+ %) across the campaign", parameters["K_c"]["reason"]).group(1)
    assert f"only {change}" in README
    diagnostics = demo["calibrate"]["diagnostics"]
    speed = re.search(r"\| `bayescal calibrate` on Table III.*\| R-hat ≤ ([\d.]+), ESS ≥ ([\d,]+) \|", SPEED)
    assert speed.group(1) == f"{diagnostics['r_hat_max']:.3f}"
    assert speed.group(2) == f"{diagnostics['ess_bulk_min']:,.0f}"


def test_every_option_of_every_command_is_documented():
    documented = README + "".join(path.read_text(encoding="utf-8") for path in sorted((ROOT / "docs").glob("*.md")))
    missing = []
    # the product's commands, and the research's (python -m bayescal_studies) beside them
    for action in (*build_parser()._actions, *build_research_parser()._actions):
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for command, parser in action.choices.items():
            for option in parser._actions:
                names = [name for name in option.option_strings if name not in ("-h", "--help")]
                if names and not any(re.search(rf"{re.escape(name)}\b", documented) for name in names):
                    missing.append(f"{command} {names[-1]}")
    assert not missing, f"options in no document: {', '.join(missing)}"


def test_the_python_example_runs_and_writes_only_into_its_own_folder(tmp_path, monkeypatch):
    code = re.search(r"```python\n(.*?)```", PYTHON, re.S).group(1)
    assert 'out = Path("example")' in code
    # run from a folder holding only the data, so that anything written elsewhere would show
    (tmp_path / "data").symlink_to(ROOT / "data")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/python.md", "exec"), {"__name__": "readme"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "example"]
    written = {p.name for p in (tmp_path / "example").iterdir()}
    assert {"geometry_posterior.nc", "calibration.nc", "program.csv", "compensated.csv", "plan.csv"} <= written


def test_the_misstated_config_figures_the_readme_quotes_are_the_committed_reports():
    report = (ROOT / "reports" / "elastostatic.md").read_text(encoding="utf-8")
    rows = {}
    for line in report.splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if len(cells) == 9 and cells[0] in ("spring 4.6x stiffer, s0 +26 %", "link masses 15 % heavier"):
            rows[cells[0].split()[0], cells[1], cells[2]] = cells
    quoted = re.search(r"0\.3 μm noise; `reports/elastostatic\.md`\) K_c = ([\d.]+) ± ([\d.]+) N/mm, s0 = ([\d.]+) ± ([\d.]+) mm\n"
                       r"\(±3σ, R-hat ([\d.]+)\)", RESULTS)
    assert quoted, "docs/results.md no longer quotes the stiffer spring's fit at 0.3 μm"
    kc, s0 = rows["spring", "0.3", "K_c"], rows["spring", "0.3", "s0"]
    assert quoted.groups()[:4] == (kc[4], kc[5], s0[4], s0[5])
    assert kc[8] == quoted.group(5)
    scale = rows["link", "0.3", "gravity_scale"]
    assert f"mass scale\ncomes out {scale[4]} ± {scale[5]} (R-hat {scale[8]})" in RESULTS
    kc9, s09 = rows["spring", "9", "K_c"], rows["spring", "9", "s0"]
    assert f"K_c = {kc9[4]} ± {kc9[5]}\nN/mm and s0 = {s09[4]} ± {s09[5]} mm (R-hat {kc9[8]})" in RESULTS


def test_the_readme_is_read_in_five_minutes_and_names_every_page_of_docs():
    assert len(README.splitlines()) <= README_LINES
    for page in sorted((ROOT / "docs").glob("*.md")):
        assert f"docs/{page.name}" in README, f"the README does not point to docs/{page.name}"
