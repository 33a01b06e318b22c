"""Tests of bayescal_studies.studies.arc_fit: the known-angle fit of the lever arc against circle fits and the Cramér-Rao bounds."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal_studies.studies.arc_fit import TABLE_I_NOISE, arc_fit_study


@pytest.mark.slow
def test_known_angle_fit_reaches_the_cramer_rao_bound_and_beats_circle_fits(layout, q2):
    # 2000 arcs: each RMSE is known to about 1.6 %, well inside the 10 % and 1.8x margins.
    study = arc_fit_study(layout, q2, TABLE_I_NOISE, 2000, np.random.default_rng(1))
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


def test_a_small_study_already_separates_the_known_angle_fit(layout, q2):
    # 200 arcs: each RMSE to about 5 %; the known-angle fit's factor of about 2 stands well clear of that.
    study = arc_fit_study(layout, q2, TABLE_I_NOISE, 200, np.random.default_rng(2))
    assert list(study.index) == ["known-angle", "geometric", "hyper", "kasa", "CRB known angles", "CRB unknown angles"]
    assert list(study.columns) == ["rmse_L_mm", "rmse_centre_mm"]
    known, bound = study.loc["known-angle"], study.loc["CRB known angles"]
    assert known["rmse_L_mm"] / bound["rmse_L_mm"] == pytest.approx(1.0, abs=0.2)
    assert study.loc["geometric", "rmse_L_mm"] > 1.5 * known["rmse_L_mm"]
    # the bounds scale with the noise, the study's errors with it
    half = arc_fit_study(layout, q2, TABLE_I_NOISE / 2, 200, np.random.default_rng(2))
    np.testing.assert_allclose(half.loc["CRB known angles"], bound / 2)
    np.testing.assert_allclose(half.loc["known-angle"], known / 2, rtol=0.01)
