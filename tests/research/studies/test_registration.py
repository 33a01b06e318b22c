"""A turned tracker's Table III campaign calibrated with and without its registration (bayescal_studies.studies.registration)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from bayescal.sampling.gibbs import GibbsSampler
from bayescal_studies.studies.registration import registration_transfer_study, transfer_findings


def test_registered_campaign_calibrates_as_the_base_frame_one_and_the_unregistered_is_biased(cell, plan, tmp_path):
    quick = {"model": "linear", "sampler": GibbsSampler(n_chains=4, n_tune=100, n_draws=200), "extensions": 0}
    with ThreadPoolExecutor(1) as executor:
        table = registration_transfer_study(cell, plan, 1, tmp_path, repeats=1, executor=executor, fit_options=quick)
    findings = transfer_findings(table)
    assert findings["rows"] >= 5
    assert findings["registered_shift_max_in_sd"] < 0.3
    assert 0.95 < findings["registered_sd_ratio"][0] and findings["registered_sd_ratio"][2] < 1.05
    assert findings["registered_deflection_error_max_um"] < 3.0
    assert findings["unregistered_deflection_error_max_um"] > 300.0
    assert findings["unregistered_shift_median_in_sd"] > 2.0 and findings["unregistered_error_pct"][0] > 1.0


@pytest.mark.slow
def test_registration_transfer_over_several_campaigns(cell, plan, tmp_path):
    findings = transfer_findings(registration_transfer_study(cell, plan, 8, tmp_path))
    # The registered fit moves by its registration's own error, a small fraction of an sd (docs/registration.md).
    assert findings["registered_shift_in_sd"] < 0.15
    assert 0.97 < findings["registered_sd_ratio"][1] < 1.03
    assert findings["unregistered_shift_median_in_sd"] > 2.0
