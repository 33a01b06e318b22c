"""Tests for bayescal/design/document.py: an assessed plan's document, its table and its warnings."""

import pytest

from bayescal.design.optimise import PlanDesigner


@pytest.fixture(scope="module")
def evaluation(cell, plan):
    return PlanDesigner(cell, model="linear").assess(plan, "table3_plan.csv")


def test_an_assessed_plan_says_its_error_widths_and_violations(evaluation):
    document = evaluation.document(hanging_only=True)
    payload = evaluation.to_json()
    text = document.as_text()
    assert document.title.startswith("predicted rms error left at the test pose after compensation (ρ0, eq 38")
    rows = {row["parameter"]: row for row in document.as_json()["sections"][0]["blocks"][0]["rows"]}
    assert rows.keys() == payload["parameters"].keys()
    table = evaluation.summary()
    assert all(rows[name]["value"] == table.loc[name, "value"] for name in rows)
    warnings = [b["paragraph"] for b in document.as_json()["sections"][0]["blocks"] if b.get("kind") == "warning"]
    assert [w for w in warnings if w.startswith("configuration ")] == [f"configuration {v['config']}: {v['reason']}" for v in payload["violations"]]
    assert text.split("\n\n")[-1].startswith("This cell hangs masses only")
    assert "| parameter | unit | value | ±3σ | width (%) | Table IV (%) |" in document.as_markdown()


def test_a_plan_written_to_a_file_says_so_first(cell):
    design = PlanDesigner(cell, model="linear").optimise(4, 2, "test-pose", rng=5, starts=1, refine_steps=30, candidates_per_angle=3)
    document = design.document("plan.csv")
    assert document.title.startswith("wrote plan.csv: 8 configurations at q2 = ")
    assert document.lead[0].text.startswith("predicted rms error left at the test pose")
    assert "This cell hangs masses only" not in document.as_text()
