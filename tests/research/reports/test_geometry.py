"""Tests of bayescal_studies.reports.geometry: the report renders the fits, Table II and the studies it is given."""

from bayescal.geometry.posterior import geometry_sampler
from bayescal_studies.reports.geometry import ARCS_FIGURE, ETA_FIGURE, REPORT_FILE, render_geometry
from bayescal_studies.studies.geometry_findings import geometry_findings


def test_report_is_rendered_with_figures(data_dir):
    sampler = geometry_sampler(n_chains=2, n_tune=200, n_draws=100)
    findings = geometry_findings(
        data_dir / "table1_geometry.csv", data_dir / "paper_reference.csv", seed=0, n_arc_rep=50, n_coverage_rep=1, sampler=sampler
    )
    files = render_geometry(findings)
    text = files[REPORT_FILE].decode("utf-8")
    assert "Beside Table II" in text
    assert "det R = -1" in text
    assert "About a_y" in text
    # claims worded from the findings: Table I's lever turns clockwise, its cylinder markers drift
    assert findings.drift_verdict == "far beyond" and "far beyond P1's noise" in text
    assert f"({findings.drift_in_noise:.1f} times its rms residual at the least)" in text
    assert "turn opposite ways" in text
    assert "| a_y | " in text and "Binomial standard error" in text
    # the model criticism: its verdict and the held-out residuals before and after
    assert "## Model criticism" in text and "Verdict: **" in text and "| P01 | " in text
    assert len(files[ARCS_FIGURE]) > 1000 and files[ARCS_FIGURE][:4] == b"\x89PNG"
    assert len(files[ETA_FIGURE]) > 1000
    # rendering twice gives the same bytes: the renderer computes nothing random
    assert render_geometry(findings)[REPORT_FILE] == files[REPORT_FILE]
