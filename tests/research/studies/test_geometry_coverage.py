"""Tests of bayescal_studies.studies.geometry_coverage: frequentist coverage of the geometry posterior's intervals."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
from bayescal_studies.studies.arc_fit import TABLE_I_NOISE
from bayescal_studies.studies.geometry_coverage import binomial_se, coverage_study, layout_truth
from bayescal.units import DEG, MM


def test_coverage_study_reports_rates_per_parameter(layout, q2):
    model = GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=100, n_draws=50))
    study = coverage_study(layout, q2, TABLE_I_NOISE, 2, model, np.random.default_rng(0))
    assert list(study.index) == ["L", "a_x", "a_y", "phi", "p2_x", "p2_y", "p0_x", "p0_y"]
    assert ((study[["covered_1", "covered_2", "covered_3"]].isin([0.0, 0.5, 1.0])).all()).all()
    assert (study["content_1"] < study["content_2"]).all()
    assert (study["content_2"] < study["content_3"]).all()
    assert (study["n_rep"] == 2).all()


def test_the_truth_of_a_layout_is_the_closed_form_geometry(table1, layout):
    _, fit = table1
    truth = layout_truth(layout)
    assert truth["L"] == pytest.approx(fit.geometry.L / MM)
    assert truth["a_x"] == pytest.approx(fit.geometry.a_x / MM)
    assert truth["a_y"] == pytest.approx(fit.geometry.a_y / MM)
    assert truth["phi"] == pytest.approx(fit.geometry.phi / DEG)


def test_binomial_standard_error():
    assert binomial_se(0.5, 100) == pytest.approx(0.05)
    assert binomial_se(1.0, 10) == 0.0
