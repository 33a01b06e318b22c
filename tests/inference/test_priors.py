"""Tests of bayescal.inference.priors: the compensator geometry's Gaussian prior and where it comes from."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.errors import InputError
from bayescal.inference.priors import PHI_SD, TABLE_II_SD, GeometryPrior, config_geometry, posterior_geometry
from bayescal.units import MM


def test_a_prior_from_draws_has_their_mean_and_covariance_and_a_gaussian_log_density():
    rng = np.random.default_rng(0)
    cov = np.diag([1e-8, 4e-8, 9e-8, 1e-6])
    draws = rng.multivariate_normal([0.18, 0.69, 0.12, 0.03], cov, size=20000)
    prior = GeometryPrior.from_draws(draws)
    np.testing.assert_allclose(prior.mean, draws.mean(axis=0))
    np.testing.assert_allclose(np.sqrt(np.diag(prior.cov)), np.sqrt(np.diag(cov)), rtol=0.03)
    assert not prior.fixed
    # One marginal sd along axis i lowers the log density by sd_i^2 (Σ^-1)_ii / 2 (one half for independent axes).
    sd = np.sqrt(np.diag(prior.cov))
    for axis in range(4):
        shifted = prior.mean + sd[axis] * np.eye(4)[axis]
        assert prior.log_density(shifted) - prior.log_density(prior.mean) == pytest.approx(-0.5 * _conditional(prior.cov, axis), rel=1e-9)


def _conditional(cov: np.ndarray, axis: int) -> float:
    """``sd_i^2 (Σ^-1)_ii``: twice the drop of a Gaussian log density one marginal sd along axis ``i``."""
    return float(cov[axis, axis] * np.linalg.inv(cov)[axis, axis])


def test_a_zero_covariance_fixes_the_geometry():
    prior = GeometryPrior(mean=np.ones(4), cov=np.zeros((4, 4)))
    assert prior.fixed and prior.log_density(np.zeros(4)) == 0.0


def test_the_config_prior_is_centred_on_the_cell_with_table_iis_widths(cell):
    prior = config_geometry(cell.compensator, "kr270.toml")
    geometry = cell.compensator
    np.testing.assert_allclose(prior.mean, [geometry.L, geometry.a_x, geometry.a_y, geometry.phi])
    np.testing.assert_allclose(np.sqrt(np.diag(prior.cov)), np.r_[TABLE_II_SD, PHI_SD])
    # Table II's ±3σ half-widths of L, a_x and a_y are 0.06, 0.70 and 0.69 mm.
    np.testing.assert_allclose(3 * TABLE_II_SD / MM, [0.06, 0.70, 0.69])
    assert "Table II" in prior.source


def test_a_saved_geometry_posterior_becomes_a_prior_and_an_elastostatic_one_is_refused(cell, short_calibration):
    prior = posterior_geometry(short_calibration["geometry"], cell.compensator)
    assert not prior.fixed and np.all(np.isfinite(prior.cov))
    assert abs(prior.mean[0] - cell.compensator.L) < 1 * MM
    with pytest.raises(InputError, match="elastostatic posterior"):
        posterior_geometry(short_calibration["calibration"], cell.compensator)
