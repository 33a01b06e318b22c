"""Tests for bayescal/design/plan_design.py: a plan's JSON read back as its findings record."""

import json

import pytest

from bayescal.design.optimise import PlanDesigner
from bayescal.design.plan_design import PlanFindings
from bayescal.errors import InputError

SMALL = {"starts": 1, "refine_steps": 30, "candidates_per_angle": 3}
"""A quick optimisation: its JSON, not its optimum, is under test."""


@pytest.fixture(scope="module")
def designer(cell):
    return PlanDesigner(cell, model="linear")


def _written(results) -> dict:
    """The JSON ``bayescal plan --json`` prints of ``results``, read back."""
    return json.loads(json.dumps(results.to_json()))


def test_a_designed_plan_s_json_round_trips_through_its_findings(designer):
    design = designer.optimise(4, 2, "test-pose", rng=5, **SMALL)
    data = _written(design)
    findings = PlanFindings.from_json(data)
    assert findings.to_json() == data and list(findings.to_json()) == list(data)
    assert findings.optimised_for == "test-pose" and findings.configurations == len(design.plan) == 8
    assert findings.q2_deg == data["q2_deg"] and len(findings.q2_deg) == 4 and findings.starts == data["starts"]
    assert set(findings.parameters) == set(data["parameters"]) and findings.extra["seed"] == data["seed"]


def test_a_scored_plan_s_json_round_trips_and_has_no_search(designer, plan):
    data = _written(designer.assess(plan, "table3_plan.csv"))
    findings = PlanFindings.from_json(data)
    assert findings.to_json() == data
    assert findings.optimised_for is None and findings.starts is None and findings.extra["plan"] == "table3_plan.csv"


@pytest.mark.parametrize(
    "content, message",
    [
        ({"criterion": 0.1, "parameters": {}}, "expected the key 'configurations' of the output of bayescal plan --json"),
        ({"criterion": "small", "parameters": {}, "configurations": 3}, "expected the key 'criterion'"),
        ({"verdict": "misfit"}, "the JSON has the key 'verdict' of another command's output; --plan expects"),
    ],
)
def test_load_refuses_a_wrong_file_in_one_line_naming_it(tmp_path, content, message):
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(content))
    with pytest.raises(InputError, match="plan.json") as error:
        PlanFindings.load(path)
    assert message in str(error.value) and "\n" not in str(error.value)
