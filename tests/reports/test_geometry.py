"""Tests of bayescal.reports.geometry: the report renders the fits, Table II and the studies."""

from bayescal.geometry.posterior import default_sampler
from bayescal.reports.geometry import write_geometry_report


def test_report_is_written_with_figures(tmp_path, data_dir):
    sampler = default_sampler(n_chains=2, n_tune=200, n_draws=100)
    path = write_geometry_report(
        data_dir / "table1_geometry.csv", tmp_path, data_dir / "paper_reference.csv", seed=0, n_arc_rep=50, n_coverage_rep=1, sampler=sampler
    )
    text = path.read_text()
    assert "Beside Table II" in text
    assert "det R = -1" in text
    assert "About a_y" in text
    # claims worded from the numbers: Table I's lever turns clockwise, its cylinder markers drift
    assert "turn opposite ways" in text
    assert "far beyond P1's noise" in text
    assert "| a_y | " in text and "Binomial standard error" in text
    # the model criticism: its verdict and the held-out residuals before and after
    assert "## Model criticism" in text and "Verdict: **" in text and "| P01 | " in text
    assert (tmp_path / "geometry_arcs.png").stat().st_size > 1000
    assert (tmp_path / "geometry_eta.png").stat().st_size > 1000
