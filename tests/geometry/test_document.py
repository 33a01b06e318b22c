"""Tests for bayescal/geometry/document.py: the geometry's document beside Table II or alone."""

import warnings

import pytest

from bayescal.geometry.arcs import read_arc_points
from bayescal.geometry.document import TABLE_II_ROWS, beside_table_ii
from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
from bayescal.reference import REFERENCE_FILE, read_paper_reference


@pytest.fixture(scope="module")
def result(data_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=100, n_draws=100))
        return model.fit(read_arc_points(data_dir / "table1_geometry.csv"), rng=0)


def test_the_posterior_stands_beside_its_closed_form_and_table_ii(result):
    reference = read_paper_reference(REFERENCE_FILE)
    document = result.document("table1.csv", 4, reference, "posterior.nc")
    lines = document.as_text().splitlines()
    assert lines[0] == "Compensator geometry from table1.csv (concentric cylinder markers, seed 4)"
    assert set(lines[3]) == {"-"} and len(lines[3]) == len(lines[2])
    rows = {row["parameter"]: row for row in document.as_json()["sections"][0]["blocks"][0]["rows"]}
    summary = result.summary()
    assert rows.keys() == set(summary.index)
    paper = beside_table_ii(summary, reference)
    assert set(paper.index) == set(TABLE_II_ROWS)
    for name in TABLE_II_ROWS:
        assert rows[name]["Table II"] == paper.loc[name, "published"] and rows[name]["mean"] == summary.loc[name, "mean"]
    assert lines[-2:] == ["Table II: Klimchik et al., published value and ±3σ half-width", "posterior saved to posterior.nc"]
    assert "| parameter | unit | mean |" in document.as_markdown()


def test_without_the_published_table_no_row_has_its_columns(result):
    document = result.document("table1.csv", 0)
    rows = document.as_json()["sections"][0]["blocks"][0]["rows"]
    assert all("Table II" not in row for row in rows)
    assert "Table II: Klimchik" not in document.as_text() and "posterior saved" not in document.as_text()
