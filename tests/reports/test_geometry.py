from pathlib import Path

import numpy as np
import pytest

from bayescal.geometry.arcs import CompensatorGeometryModel, MarkerLayout, read_arc_points
from bayescal.geometry.posterior import GeometryPosteriorModel, default_sampler
from bayescal.reports.geometry import STUDY_SIGMA, arc_fit_study, coverage_study, write_geometry_report
from bayescal.units import DEG

DATA = Path(__file__).resolve().parents[2] / "data"

Q2 = np.array([-0.01, -30, -60, -90, -120, -145]) * DEG


@pytest.fixture(scope="module")
def layout():
    points = read_arc_points(DATA / "table1_geometry.csv")
    return MarkerLayout.from_fit(CompensatorGeometryModel().fit(points), points)


def test_known_angle_fit_reaches_the_cramer_rao_bound_and_beats_circle_fits(layout):
    # 2000 arcs: each RMSE is known to about 1.6 %, well inside the 10 % and 1.8x margins.
    study = arc_fit_study(layout, Q2, STUDY_SIGMA, 2000, np.random.default_rng(1))
    known = study.loc["known-angle"]
    bound = study.loc["CRB known angles"]
    assert known["rmse_L_mm"] / bound["rmse_L_mm"] == pytest.approx(1.0, abs=0.1)
    assert known["rmse_centre_mm"] / bound["rmse_centre_mm"] == pytest.approx(1.0, abs=0.1)
    best = study.loc[["geometric", "hyper"]].min()
    assert best["rmse_L_mm"] >= 1.8 * known["rmse_L_mm"]
    assert best["rmse_centre_mm"] >= 1.8 * known["rmse_centre_mm"]
    # The circle fits are themselves near their own bound, the one without angles.
    unknown = study.loc["CRB unknown angles"]
    assert study.loc["geometric", "rmse_centre_mm"] / unknown["rmse_centre_mm"] == pytest.approx(1.0, abs=0.1)


def test_coverage_study_reports_rates_per_parameter(layout):
    model = GeometryPosteriorModel(sampler=default_sampler(n_chains=2, n_tune=100, n_draws=50))
    study = coverage_study(layout, Q2, STUDY_SIGMA, 2, model, np.random.default_rng(0))
    assert list(study.index) == ["L", "a_x", "a_y", "phi", "p2_x", "p2_y", "p0_x", "p0_y"]
    assert ((study[["covered_1", "covered_2", "covered_3"]].isin([0.0, 0.5, 1.0])).all()).all()
    assert (study["content_1"] < study["content_2"]).all()
    assert (study["content_2"] < study["content_3"]).all()


def test_report_is_written_with_figures(tmp_path):
    sampler = default_sampler(n_chains=2, n_tune=200, n_draws=100)
    path = write_geometry_report(
        DATA / "table1_geometry.csv", tmp_path, DATA / "paper_reference.csv", seed=0, n_arc_rep=50, n_coverage_rep=1, sampler=sampler
    )
    text = path.read_text()
    assert "Beside Table II" in text
    assert "det R = -1" in text
    assert "About a_y" in text
    assert (tmp_path / "geometry_arcs.png").stat().st_size > 1000
    assert (tmp_path / "geometry_eta.png").stat().st_size > 1000
