import warnings

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.inference.residuals import COVARIATES, residual_table
from bayescal.units import UM


@pytest.fixture(scope="module")
def fitted(cell, campaign_csv):
    campaign = read_campaign(campaign_csv, cell=cell)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=2, n_tune=50, n_draws=100)).fit(campaign, 0)
    return campaign, results


def test_table_has_one_row_per_measurement_with_covariates_and_residuals(cell, fitted):
    campaign, results = fitted
    table = residual_table(results, campaign, cell)
    assert len(table) == len(campaign)
    assert set(COVARIATES) <= set(table.columns)
    np.testing.assert_allclose(table["q2_deg"], np.degrees(campaign.q[:, 1]))
    np.testing.assert_allclose(table[["residual_x_um", "residual_y_um", "residual_z_um"]].to_numpy(), results.residuals / UM)
    assert np.sqrt(np.mean(table[["residual_x_um", "residual_y_um", "residual_z_um"]].to_numpy() ** 2)) == pytest.approx(
        results.residual_rms / UM
    )
    assert table["tracker_distance_mm"].min() > 1000  # the tracker stands metres from the markers


def test_twin_residuals_look_like_the_tracker_noise(cell, fitted):
    """On the twin's campaign the model is right: residuals are the tracker's noise, normalised rms about 1."""
    campaign, results = fitted
    table = residual_table(results, campaign, cell)
    # Fewer than 3 rows in 45 beyond 3 sd; the rms somewhat below 1, as fitted residuals are.
    assert np.sqrt(np.mean(table["normalised"] ** 2)) == pytest.approx(1.0, abs=0.25)
    assert (table["normalised"] > 3).sum() < 3


def test_results_of_another_campaign_are_refused(cell, fitted):
    campaign, results = fitted
    shorter = type(campaign)(**{name: getattr(campaign, name)[:10] for name in ("config", "repeat", "marker", "q", "wrench", "p0", "p1", "lines")})
    with pytest.raises(ValueError, match="residual rows"):
        residual_table(results, shorter, cell)
