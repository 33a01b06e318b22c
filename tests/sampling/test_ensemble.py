"""Tests of bayescal.sampling.ensemble: emcee's ensembles behind the sampler protocol, on a known density."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.sampling.diagnostics import rhat
from bayescal.sampling.ensemble import EnsembleSampler


def gaussian(mean: np.ndarray, sd: np.ndarray):
    def log_prob(x: np.ndarray) -> float:
        return float(-0.5 * np.sum(((x - mean) / sd) ** 2))

    return log_prob


def test_draws_have_the_protocol_shape_and_the_target_moments():
    mean, sd = np.array([1.0, -2.0]), np.array([0.5, 3.0])
    sampler = EnsembleSampler(n_chains=3, n_tune=300, n_draws=600)
    draws = sampler.sample(gaussian(mean, sd), mean + 0.1, sd, np.random.default_rng(0))
    walkers = sampler.walkers_for(2)
    assert draws.shape == (3, walkers * 600, 2)
    flat = draws.reshape(-1, 2)
    # about 16 × 3 × 600 correlated draws: the moments to within a few per cent of the sd
    assert np.all(np.abs(flat.mean(axis=0) - mean) < 0.1 * sd)
    np.testing.assert_allclose(flat.std(axis=0), sd, rtol=0.1)
    # independent ensembles are chains R-hat can compare
    assert all(rhat(draws[..., k]) < 1.05 for k in range(2))


def test_the_same_generator_state_gives_the_same_draws_and_another_other_draws():
    target, sampler = gaussian(np.zeros(3), np.ones(3)), EnsembleSampler(n_chains=2, n_tune=20, n_draws=30)
    first = sampler.sample(target, np.zeros(3), np.ones(3), np.random.default_rng(5))
    again = sampler.sample(target, np.zeros(3), np.ones(3), np.random.default_rng(5))
    other = sampler.sample(target, np.zeros(3), np.ones(3), np.random.default_rng(6))
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_walkers_stay_inside_the_support():
    def positive(x: np.ndarray) -> float:
        return float(-np.sum(x)) if np.all(x > 0) else -np.inf

    draws = EnsembleSampler(n_chains=2, n_tune=50, n_draws=100).sample(positive, np.full(2, 0.5), np.full(2, 0.4), np.random.default_rng(1))
    assert np.all(draws > 0)


def test_walker_counts_are_even_and_thinning_keeps_every_kth_step():
    assert EnsembleSampler().walkers_for(3) == 16
    assert EnsembleSampler().walkers_for(10) == 22
    assert EnsembleSampler(n_walkers=9).walkers_for(2) == 10
    draws = EnsembleSampler(n_chains=1, n_tune=10, n_draws=40, thin=4).sample(gaussian(np.zeros(1), np.ones(1)), np.zeros(1), np.ones(1), np.random.default_rng(2))
    assert draws.shape == (1, 16 * 10, 1)
    assert "emcee, 1 independent ensembles of 16 walkers" in EnsembleSampler(n_chains=1).describe(1)


def test_a_start_outside_the_support_is_refused():
    with pytest.raises(ValueError, match="not finite at the starting point"):
        EnsembleSampler(n_chains=1).sample(lambda x: -np.inf, np.zeros(2), np.ones(2), np.random.default_rng(0))
