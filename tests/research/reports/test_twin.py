"""Tests of bayescal_studies.reports.twin and its findings: the generated report carries the computed numbers."""

from __future__ import annotations

import os
import shutil

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal_studies.cli import main
from bayescal_studies.reports.twin import REPORT_FILE, render_twin
from bayescal_studies.studies.precision import design_precision
from bayescal_studies.studies.twin_findings import twin_findings


def test_report_tables(data_dir):
    cell = load_cell(data_dir / "kr270.toml")
    plan = read_plan(data_dir / "table3_plan.csv", cell.robot)
    findings = twin_findings(cell, plan)
    text = render_twin(findings)[REPORT_FILE].decode("utf-8")
    assert "405 equations" in text
    precision = design_precision(cell, plan)
    assert f"| k2 | 0.302 urad/(N m) | {precision.loc['k2', 'sd']:.3g} | {precision.loc['k2', 'width_3sd_pct']:.2f} | 1.3 |" in text
    assert "| k1 | 0.3 urad/(N m) | not excited |" in text
    for name in ("link_compliance", "tool_compliance", "nonlinear_stiffness", "backlash", "outliers", "compensator=0"):
        assert name in text
    gravity = cell.robot.gravity_torque([0.0] * 6)[1]
    spring = -cell.compensator.torque(0.0)
    assert f"| 0 | {gravity:.0f} | {spring:.0f} | {gravity - spring:.0f} |" in text
    # the verdict of each effect is the findings', not the renderer's
    for effect in findings.effects:
        assert effect.detectable == (effect.detectability["noncentrality"] >= findings.chi2_spread)


def _paper_data(tmp_path, data_dir):
    """A --paper-data folder: copies of the paper's files, the robot models linked."""
    folder = tmp_path / "data"
    folder.mkdir()
    for name in ("table1_geometry.csv", "paper_reference.csv", "kr270.toml", "table3_plan.csv", "compensator_plan.csv"):
        shutil.copy(data_dir / name, folder / name)
    os.symlink(data_dir / "robots", folder / "robots")
    return folder


def test_paper_reports_write_the_twin_report_through_the_command_line(tmp_path, data_dir, capsys):
    folder = _paper_data(tmp_path, data_dir)
    out = tmp_path / "reports"
    assert main(["reports", str(out), "--paper-data", str(folder), "--only", "twin", "--json"]) == 0
    cell = load_cell(folder / "kr270.toml")
    expected = render_twin(twin_findings(cell, read_plan(folder / "table3_plan.csv", cell.robot), seed=1))[REPORT_FILE]
    assert (out / "twin.md").read_bytes() == expected
    assert sorted(os.listdir(out)) == ["twin.md"]


def test_the_report_is_not_written_over_its_plan_even_through_a_link(tmp_path, data_dir, capsys):
    folder = _paper_data(tmp_path, data_dir)
    plan = folder / "table3_plan.csv"
    out = tmp_path / "reports"
    out.mkdir()
    os.symlink(plan, out / "twin.md")
    assert main(["reports", str(out), "--paper-data", str(folder), "--only", "twin"]) == 2
    assert "FOLDER: " in capsys.readouterr().err
    assert plan.read_bytes() == (data_dir / "table3_plan.csv").read_bytes()


def test_the_product_command_line_writes_no_paper_report(tmp_path, capsys):
    from bayescal.cli import main as bayescal

    assert bayescal(["report", "--paper-reports", str(tmp_path)]) == 2
    assert "unrecognized arguments: --paper-reports" in capsys.readouterr().err
    assert main(["reports", str(tmp_path), "--only", "paper"]) == 2
    assert "python -m bayescal_studies reports: error: argument --only" in capsys.readouterr().err
