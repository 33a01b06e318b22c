"""Tests for bayescal/critique/results.py: a critique's JSON read back as its findings record."""

import json

import numpy as np
import pytest

from bayescal.critique import Critique
from bayescal.critique.geometry import GeometryCritique
from bayescal.critique.results import CritiqueFindings
from bayescal.errors import InputError
from bayescal.geometry.arcs import read_arc_points


@pytest.fixture(scope="module")
def backlash(cell, twin_campaign):
    return Critique(cell).run(twin_campaign(["backlash"], seed=2), np.random.default_rng(0))


def _written(results) -> dict:
    """The JSON ``bayescal critique --json`` prints of ``results``, read back."""
    return json.loads(json.dumps(results.to_json()))


def test_a_campaign_critique_s_json_round_trips_through_its_findings(backlash):
    data = _written(backlash)
    findings = CritiqueFindings.from_json(data)
    assert findings.to_json() == data and list(findings.to_json()) == list(data)
    assert findings.verdict == backlash.verdict == "misfit" and findings.causes == backlash.causes
    assert findings.evidence["backlash"]["delta_elpd"] == pytest.approx(backlash.evidence["backlash"].delta_elpd, abs=0.01)
    assert findings.negligible == backlash.negligible and findings.lack_of_fit["level"] == 0.01
    # The keys the record has no field for are kept as they came: the review lists them.
    assert {"settings", "importance", "drift", "contested_by"} <= set(findings.extra)


def test_a_geometry_critique_s_json_round_trips_and_lacks_what_it_never_writes(data_dir):
    data = _written(GeometryCritique().run(read_arc_points(data_dir / "table1_geometry.csv")))
    findings = CritiqueFindings.from_json(data)
    assert findings.to_json() == data and "lack_of_fit" not in findings.to_json()
    assert findings.lack_of_fit is None and findings.extra["n_angles"] == data["n_angles"]


def test_a_record_built_in_code_writes_its_fields():
    findings = CritiqueFindings("adequate", [], {}, {"delta_elpd": 0.4}, extra={"something_new": 1})
    assert findings.to_json() == {"verdict": "adequate", "causes": [], "evidence": {}, "gain": {"delta_elpd": 0.4}, "something_new": 1}


@pytest.mark.parametrize(
    "content, message",
    [
        ({"verdict": "misfit", "causes": [], "evidence": {}}, "expected the key 'gain' of the output of bayescal critique --json"),
        ({"verdict": "perhaps", "causes": [], "evidence": {}, "gain": {}}, "expected a verdict adequate or misfit, got 'perhaps'"),
        ({"parameters": {}}, "the JSON has the key 'parameters' of another command's output; --critique expects"),
        ([1], "expected a JSON object"),
    ],
)
def test_load_refuses_a_wrong_file_in_one_line_naming_it(tmp_path, content, message):
    path = tmp_path / "critique.json"
    path.write_text(json.dumps(content))
    with pytest.raises(InputError, match="critique.json") as error:
        CritiqueFindings.load(path)
    assert message in str(error.value) and "\n" not in str(error.value)
