"""Tests of bayescal_studies.studies.independent_residuals: residuals of the fit on the independent generator's campaigns."""

from __future__ import annotations

import pytest

from bayescal_studies.studies.independent_residuals import effect_residuals


def test_outliers_raise_the_residuals_above_the_noise(cell):
    table = effect_residuals(cell, [1], effects=[None, "los_jumps"]).set_index("effect")
    assert list(table.columns) == [
        "cause", "seed", "change_um", "noise_um", "residual_rms_um", "chi2_per_dof", "r_hat_max", "ess_bulk_min",
        "error",
    ]
    assert table["error"].isna().all()
    # Without an effect the residuals are the noise; 3 % of readings off by 0.5-1.5 mm are not.
    assert table.loc["none", "change_um"] == 0.0
    assert table.loc["none", "residual_rms_um"] == pytest.approx(table.loc["none", "noise_um"], rel=0.15)
    assert table.loc["los_jumps", "chi2_per_dof"] > 4.0 * table.loc["none", "chi2_per_dof"]
    assert table.loc["los_jumps", "cause"] == "outliers"
