"""Tests of bayescal.inference.posterior: sampling the elastostatic posterior and the inverse map of saved draws."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.equations import deflection_equations
from bayescal.inference.posterior import posterior_density, sample_posterior, sampler_coordinates
from bayescal.inference.priors import config_geometry
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.twin.simulator import DigitalTwin


@pytest.mark.parametrize("compensated", [True, False])
def test_saved_draws_map_back_to_the_coordinates_that_give_the_fits_residuals(cell, plan, compensated):
    campaign = DigitalTwin(cell).simulate(plan, 1, np.random.default_rng(8))
    model = ElastostaticModel.from_cell(cell, model="linear")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cf, ident = model.estimate(campaign)
    if not compensated:
        ident = replace(ident, compensator=False)
    equations = deflection_equations(cell.robot, campaign, tracker=cell.tracker, joint=cell.compensated_joint)[0].whitened()
    prior = config_geometry(cell.compensator)
    spring = (cell.compensator.K_c, cell.compensator.s0)
    sampler = GibbsSampler(n_chains=2, n_tune=30, n_draws=40)
    tree, draws, residual, n_free = sample_posterior(equations, ident, cf, sampler, prior, spring, np.random.default_rng(0))
    posterior, joints = posterior_density(equations, ident, prior)
    assert (joints is not None) == compensated and n_free == posterior.ndim - posterior.n_groups
    coordinates = sampler_coordinates(posterior, joints, draws, equations, ident)
    assert coordinates.shape == (2 * 40, posterior.ndim)
    assert np.all(np.isfinite([posterior(theta) for theta in coordinates[:5]]))
    np.testing.assert_allclose(posterior.residual(coordinates.mean(axis=0)), residual, rtol=1e-6, atol=1e-9 * np.abs(residual).max())
    assert (tree["posterior"].sizes["chain"], tree["posterior"].sizes["draw"]) == (2, 40)
