"""Tests for bayescal/critique/document.py: a critique's document says what its JSON says, in every rendering."""

import json
from xml.etree import ElementTree

import numpy as np
import pytest

from bayescal.critique import Critique
from bayescal.critique.geometry import GEOMETRY_CATALOGUE, GeometryCritique
from bayescal.critique.results import CRITIQUE_JSON
from bayescal.geometry.arcs import read_arc_points


@pytest.fixture(scope="module")
def backlash(cell, twin_campaign):
    campaign = twin_campaign(["backlash"], seed=2)
    return Critique(cell).run(campaign, np.random.default_rng(0))


@pytest.fixture(scope="module")
def geometry(data_dir):
    points = read_arc_points(data_dir / "table1_geometry.csv")
    return GeometryCritique().run(points)


def _evidence_rows(document) -> dict:
    table = document.as_json()["sections"][0]["blocks"][0]
    assert table["table"] == "evidence" and [c["unit"] for c in table["columns"]] == ["", "", "nats", "nats", ""]
    return {row["candidate"]: row for row in table["rows"]}


def test_the_campaign_critique_document_gives_the_verdict_evidence_and_next_step(backlash):
    document = backlash.document(["figures/residuals.png"])
    payload = backlash.to_json()
    CRITIQUE_JSON.check_keys(payload, "critique.json")
    rows = _evidence_rows(document)
    assert rows.keys() == payload["evidence"].keys()
    assert all(rows[name]["ΔELPD"] == entry["delta_elpd"] and rows[name]["named"] == entry["named"] for name, entry in payload["evidence"].items())
    text = document.as_text()
    assert text.splitlines()[1] == "verdict: misfit - causes in order of gain: " + ", ".join(payload["causes"])
    assert "figures: figures/residuals.png" in text and text.split("\n\n")[-1].startswith("Next:")
    assert "| candidate | step | ΔELPD (nats) | SE (nats) | named |" in document.as_markdown()
    root = ElementTree.fromstring(document.as_html())
    assert [td.text for td in root.find("section/table/tbody/tr")][0] in payload["evidence"]
    json.dumps(document.as_json(), allow_nan=False)


def test_the_geometry_critique_document_names_every_candidate_and_the_rule(geometry):
    document = geometry.document()
    assert _evidence_rows(document).keys() == set(GEOMETRY_CATALOGUE)
    text = document.as_text()
    assert text.startswith(f"{geometry.source}: 18 points at 6 joint angles")
    assert text.splitlines()[1].startswith("verdict: " + geometry.verdict)
    # six held-out angles: the SE's own relative sd sqrt(1 / (2 * 5)) is about 32 %
    assert text.rstrip().endswith("the SE itself is uncertain by about 32 %")
