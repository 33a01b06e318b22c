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


def test_a_discriminating_plan_lists_its_configurations_as_pandas_prints_them(cell, twin_campaign):
    from bayescal.design.constraints import load_design_space
    from bayescal.design.discriminate import DiscriminatingDesigner
    from bayescal.numbers import fixed, table_texts

    campaign = twin_campaign(["backlash"], seed=2)
    designer = DiscriminatingDesigner(cell, ("backlash", "nonlinear_stiffness"), campaign, load_design_space(cell))
    design = designer.optimise(3, 4, 0, starts=1)
    document = design.document("plan.csv", "tied.csv")
    assert document.title.startswith(f"wrote plan.csv: {len(design.plan)} configurations at q2 = ")
    assert "(nats; tied.csv in brackets)" in document.lead[0].text and document.lead[1].text == design.order
    table = design.summary()
    expected = table_texts(table, {}, {column: fixed(1) for column in table.columns}).to_string()
    assert document.as_text().split("\n", 3)[3] == expected
    columns = document.as_json()["lead"][2]["columns"]
    assert [c["unit"] for c in columns] == ["", *["deg"] * 6, "kg"]
