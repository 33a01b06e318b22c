"""Tests of bayescal_studies.studies.sensitivity: the exact model's dependence on the link masses and the nominal spring."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.twin.simulator import DigitalTwin
from bayescal_studies.studies.sensitivity import assumption_sensitivity


@pytest.fixture(scope="module")
def campaign(cell, plan):
    return DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))


def test_changes_in_the_assumptions_move_the_estimates_by_a_fraction_of_their_sd(cell, campaign):
    model = ElastostaticModel.from_cell(cell)
    posterior = pd.DataFrame({"mean": [0.3, 0.4, 3.0], "sd": [0.0015, 0.0027, 0.026]}, index=["k2", "k3", "k4"])
    shifts = assumption_sensitivity(model, campaign, posterior)
    assert list(shifts.columns) == ["link masses ×0.8", "link masses ×1.2", "nominal K_c ×0.8", "nominal K_c ×1.2"]
    assert list(shifts.index) == ["k2", "k3", "k4"]
    # the correction is small and, for ±20 %, linear in the change: opposite changes move the estimates oppositely
    assert (shifts.abs() < 0.5).all().all()
    np.testing.assert_allclose(shifts["link masses ×0.8"], -shifts["link masses ×1.2"], rtol=0.05, atol=1e-3)
    np.testing.assert_allclose(shifts["nominal K_c ×0.8"], -shifts["nominal K_c ×1.2"], rtol=0.05, atol=1e-3)
    # shifts are counted in the posterior sd
    halved = assumption_sensitivity(model, campaign, posterior.assign(sd=posterior["sd"] / 2))
    np.testing.assert_allclose(halved, 2 * shifts)


def test_a_parameter_the_closed_form_does_not_estimate_is_left_out(cell, campaign):
    model = ElastostaticModel.from_cell(cell)
    posterior = pd.DataFrame({"mean": [0.3, 0.3], "sd": [0.01, 0.01]}, index=["k1", "k2"])
    assert list(assumption_sensitivity(model, campaign, posterior).index) == ["k2"]
