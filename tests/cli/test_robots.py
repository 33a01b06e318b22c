"""Every command on the test robots of ``data/robots/``: seven joints, no compensator, a compensator on joint 3, a linear track.

The robots and their cells are the project's own (``data/robots/*.urdf`` and ``*.toml``);
their campaigns are simulated from random plans, not from the KR-270's Table III.
"""

import json

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.cell.config import load_cell
from bayescal.cell.plan import write_plan
from bayescal.cli import main
from bayescal_studies.studies.elastostatic_coverage import random_plan

ROBOTS = ("arm7", "arm6", "arm6_j3", "track_arm6")


def run(capsys, argv) -> dict:
    status = main([*argv, "--json"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    return json.loads(captured.out)


@pytest.mark.parametrize("name", ROBOTS)
def test_simulate_calibrate_plan_critique_report_and_compensate_run(capsys, tmp_path, data_dir, name):
    config = data_dir / "robots" / f"{name}.toml"
    cell = load_cell(config)
    plan = tmp_path / "plan.csv"
    write_plan(random_plan(cell, 4, 3, np.random.default_rng(3)), plan)
    campaign = tmp_path / "campaign.csv"
    run(capsys, ["simulate", "--plan", str(plan), "--config", str(config), "--repeats", "1", "--seed", "2", "-o", str(campaign)])
    # A prismatic joint's column is in mm, the others in deg; the plan file keeps 0.001 deg and 0.001 mm.
    header = next(line for line in campaign.read_text().splitlines() if not line.startswith("#")).split(",")
    assert [column for column in header if column.startswith("q")] == list(cell.robot.position_columns)
    np.testing.assert_allclose(read_campaign(campaign, cell=cell).q[::3], random_plan(cell, 4, 3, np.random.default_rng(3)).q, atol=2e-5)

    posterior = tmp_path / "posterior.nc"
    calibration = run(
        capsys, ["calibrate", str(campaign), "--config", str(config), "--draws", "100", "--seed", "1", "--posterior", str(posterior)]
    )
    parameters = calibration["parameters"]
    spring = {"K_c", "s0"} if cell.compensator is not None else set()
    assert set(parameters) == {f"k{j + 1}" for j in range(cell.robot.nq)} | spring
    # Without a compensator no compliance is per angle, and nothing is said of a spring.
    assert bool(calibration["k2_per_angle"]) == (cell.compensator is not None)
    assert ("K_c" in json.dumps(calibration["identifiability"])) == (cell.compensator is not None)
    # The compensated joint's (joint 2's without one) own compliance and its neighbours' are the cell's, within their intervals.
    middle = 1 if cell.compensated_joint is None else cell.compensated_joint
    for joint in (middle - 1, middle, middle + 1):
        entry = parameters[f"k{joint + 1}"]
        if "mean" in entry:
            assert entry["lo3"] <= cell.compliances[joint] * 1e6 <= entry["hi3"], (joint, entry)
    assert "mean" in parameters[f"k{middle + 1}"]
    if name in ("arm6_j3", "arm6"):
        # The text too names no published table: the cell names none.
        assert main(["calibrate", str(campaign), "--config", str(config), "--draws", "100", "--seed", "1"]) == 0
        assert "Table IV" not in capsys.readouterr().out

    plan_json = tmp_path / "plan.json"
    scored = run(capsys, ["plan", "--config", str(config), "--evaluate", str(plan)])
    assert scored["criterion"] is not None and "table_iv_pct" not in json.dumps(scored)
    assert ("K_c" in scored["parameters"]) == (cell.compensator is not None)
    plan_json.write_text(json.dumps(scored))
    critique_json = tmp_path / "critique.json"
    critique = run(capsys, ["critique", str(campaign), "--config", str(config)])
    critique_json.write_text(json.dumps(critique))

    report = run(
        capsys,
        ["report", "--calibration", str(posterior), "--campaign", str(campaign), "--config", str(config)]
        + ["--plan", str(plan_json), "--critique", str(critique_json), "-o", str(tmp_path / "report")],
    )
    page = (tmp_path / "report" / "index.md") if (tmp_path / "report" / "index.md").exists() else None
    assert report and (tmp_path / "report").is_dir()
    if page is not None:
        assert "Table IV" not in page.read_text()

    # The calibration compensates a one-pose program at the cell's test pose.
    program = tmp_path / "program.csv"
    header = [*cell.robot.position_columns, "fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm"]
    row = [*(cell.test_q / np.where(cell.robot.prismatic, 1e-3, np.pi / 180)), *cell.test_wrench]
    program.write_text(",".join(header) + "\n" + ",".join(f"{v:.6g}" for v in row) + "\n")
    compensated = run(capsys, ["compensate", str(program), "--calibration", str(posterior), "--config", str(config), "-o", str(tmp_path / "out.csv")])
    assert compensated["summary"]["no_equilibrium"] == 0 and (tmp_path / "out.csv").is_file()
