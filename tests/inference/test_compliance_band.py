"""Tests of bayescal.inference.compliance_band: Fig. 7's band of the equivalent joint-2 compliance."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.inference.compliance_band import equivalent_compliance_band


@pytest.fixture(scope="module")
def results(short_exact_fit):
    return short_exact_fit


def test_the_band_of_the_equivalent_compliance_is_the_posteriors_99_73_percent(cell, results):
    band = equivalent_compliance_band(results, cell, n_points=7)
    assert len(band) == 7 and band.index.name == "q2_deg"
    assert band.index[0] == pytest.approx(np.degrees(cell.robot.lower[1])) and band.index[-1] == pytest.approx(np.degrees(cell.robot.upper[1]))
    draws = results.equivalent_compliance(np.radians(band.index.to_numpy())) / 1e-6
    # 0.135 % in each tail: the paper's ±3σ content
    np.testing.assert_allclose(band["low_urad_per_Nm"], np.quantile(draws, 0.00135, axis=0))
    np.testing.assert_allclose(band["high_urad_per_Nm"], np.quantile(draws, 0.99865, axis=0))
    assert (band["low_urad_per_Nm"] < band["median_urad_per_Nm"]).all()
    assert (band["median_urad_per_Nm"] < band["high_urad_per_Nm"]).all()
    # the twin's truth: eq 8 with the cell's compliance and spring, about 0.3 μrad/(N·m)
    assert band["truth_urad_per_Nm"].to_numpy() == pytest.approx(0.3, rel=0.02)
    assert band["half_width_pct"].to_numpy() == pytest.approx(
        (50 * (band["high_urad_per_Nm"] - band["low_urad_per_Nm"]) / band["median_urad_per_Nm"]).to_numpy()
    )
