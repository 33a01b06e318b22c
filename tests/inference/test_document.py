"""Tests for bayescal/inference/document.py: the calibration's document, beside Table IV or not."""

import warnings

import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.compensation.testpose import predict_cell_test_pose
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.sampling.gibbs import GibbsSampler


@pytest.fixture(scope="module")
def fitted(cell, campaign_csv):
    """A short linear fit of the one-repeat Table III campaign (too short to converge: the document must say so)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = ElastostaticModel.from_cell(cell, model="linear", sampler=GibbsSampler(n_chains=2, n_tune=100, n_draws=150))
        results = model.fit(read_campaign(campaign_csv, cell=cell), 0)
        return results, predict_cell_test_pose(results, cell)


def test_the_parameters_stand_beside_table_iv_with_their_units_and_numbers(fitted, cell):
    results, test_pose = fitted
    document = results.document(test_pose, "campaign.csv", 7, cell.reference)
    lines = document.as_text().splitlines()
    assert lines[0].startswith(f"campaign.csv: {results.n_equations} equations") and lines[0].endswith("seed 7")
    assert lines[2] == f"{'parameter':<10}{'unit':<12}{'mean':>10}{'±3σ':>10}{'width':>8}   | {'Table IV':>9}{'±3σ':>8}{'width':>8}"
    table = document.as_json()["sections"][0]["blocks"][0]
    rows = {row["parameter"]: row for row in table["rows"]}
    parameters = results.parameters()
    assert rows.keys() == parameters.keys()
    for name, entry in parameters.items():
        assert rows[name]["unit"] == results.parameter_units[name]
        if "mean" in entry:
            assert rows[name]["mean"] == pytest.approx(entry["mean"])
    # k1 under hanging loads: one cell over three columns in the text and the HTML
    assert any(line.startswith("k1") and "not identifiable" in line for line in lines)
    assert '<td colspan="3">not identifiable</td>' in document.as_html()
    headings = [section["heading"] for section in document.as_json()["sections"]]
    assert "Not identifiable:" in headings and any(h.startswith("Joint 2 with its compensator") for h in headings)
    assert "## Not identifiable\n" in document.as_markdown()


def test_without_a_published_table_the_parameters_stand_alone(fitted):
    results, test_pose = fitted
    document = results.document(test_pose, "campaign.csv", 0)
    assert "Table IV" not in document.as_text()
    assert [c["name"] for c in document.as_json()["sections"][0]["blocks"][0]["columns"]] == ["parameter", "unit", "mean", "±3σ", "width"]


def test_a_test_pose_not_predicted_is_said_so(fitted):
    results, _ = fitted

    class Unavailable:
        def to_json(self):
            return {"available": False, "reason": "the cell names no test pose"}

    text = results.document(Unavailable(), "campaign.csv", 0).as_text()
    assert "test pose: not predicted: the cell names no test pose" in text
