"""Tests of bayescal.reports.twin: the generated report carries the computed numbers."""

from __future__ import annotations

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.studies.precision import design_precision
from bayescal.reports.twin import main, render_report


def test_report_tables(tmp_path, data_dir):
    cell = load_cell(data_dir / "kr270.toml")
    plan = read_plan(data_dir / "table3_plan.csv", cell.robot)
    text = render_report(cell, plan)
    assert "405 equations" in text
    precision = design_precision(cell, plan)
    assert f"| k2 | 0.302 urad/(N m) | {precision.loc['k2', 'sd']:.3g} | {precision.loc['k2', 'width_3sd_pct']:.2f} | 1.3 |" in text
    assert "| k1 | 0.3 urad/(N m) | not excited |" in text
    for name in ("link_compliance", "tool_compliance", "nonlinear_stiffness", "backlash", "outliers", "compensator=0"):
        assert name in text
    gravity = cell.robot.gravity_torque([0.0] * 6)[1]
    spring = -cell.compensator.torque(0.0)
    assert f"| 0 | {gravity:.0f} | {spring:.0f} | {gravity - spring:.0f} |" in text
    out = tmp_path / "twin.md"
    main(["--config", str(data_dir / "kr270.toml"), "--plan", str(data_dir / "table3_plan.csv"), "-o", str(out)])
    assert out.read_text() == text


def test_the_report_is_not_written_over_its_plan_even_through_a_link(tmp_path, data_dir):
    import os

    import pytest

    from bayescal.errors import InputError

    plan = tmp_path / "plan.csv"
    plan.write_bytes((data_dir / "table3_plan.csv").read_bytes())
    os.symlink(plan, tmp_path / "twin.md")
    with pytest.raises(InputError, match="--output: .*twin.md is the plan"):
        main(["--config", str(data_dir / "kr270.toml"), "--plan", str(plan), "-o", str(tmp_path / "twin.md")])
    assert plan.read_bytes() == (data_dir / "table3_plan.csv").read_bytes()
