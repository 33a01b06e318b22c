import math

import numpy as np
import pytest

from bayescal.sampling import diagnostics
from bayescal.sampling.independence import IndependenceSampler, evaluate, laplace

MEAN = np.array([10.0, -2.0, 0.5])
COV = np.array([[1.0, 0.6, 0.0], [0.6, 4.0, -0.3], [0.0, -0.3, 0.09]])
PRECISION = np.linalg.inv(COV)


class Gaussian:
    """A correlated Gaussian log-density that takes one vector or a batch."""

    vectorized = True

    def __call__(self, x):
        d = np.asarray(x) - MEAN
        return -0.5 * np.einsum("...i,ij,...j->...", d, PRECISION, d)


class StudentT:
    """A multivariate Student t with 6 degrees of freedom, scale matrix COV: tails like the geometry posterior's."""

    vectorized = True
    dof = 6.0

    def __call__(self, x):
        d = np.asarray(x) - MEAN
        quad = np.einsum("...i,ij,...j->...", d, PRECISION, d)
        return -0.5 * (self.dof + MEAN.size) * np.log1p(quad / self.dof)


def test_laplace_finds_the_mode_and_covariance_of_a_gaussian_from_afar():
    mode, cov = laplace(Gaussian(), MEAN + np.array([3.0, -5.0, 0.4]), np.ones(3))
    np.testing.assert_allclose(mode, MEAN, atol=1e-6)
    np.testing.assert_allclose(cov, COV, rtol=1e-6, atol=1e-9)


def test_student_t_target_is_sampled_with_its_mean_and_sd():
    target = StudentT()
    draws = IndependenceSampler(n_chains=4, n_draws=2000).sample(target, MEAN + 0.5, np.sqrt(np.diag(COV)), np.random.default_rng(1))
    assert draws.shape == (4, 2000, 3)
    sd = np.sqrt(np.diag(COV) * target.dof / (target.dof - 2))
    for i in range(3):
        ess = diagnostics.ess_bulk(draws[..., i])
        assert ess > 2000
        assert diagnostics.rhat(draws[..., i]) < 1.01
        assert abs(draws[..., i].mean() - MEAN[i]) < 4 * sd[i] / math.sqrt(ess)
        assert draws[..., i].std() == pytest.approx(sd[i], rel=0.08)
    # mean ± 3 sd of a t with 6 degrees of freedom holds 98.96 % of it (|t| <= 3·sqrt(3/2))
    inside = np.abs(draws[..., 1] - MEAN[1]) <= 3 * sd[1]
    assert inside.mean() == pytest.approx(0.9896, abs=0.005)


def test_a_scalar_log_prob_gives_the_same_draws_one_call_at_a_time():
    target = Gaussian()
    sampler = IndependenceSampler(n_chains=2, n_tune=20, n_draws=50)
    batched = sampler.sample(target, MEAN, np.ones(3), np.random.default_rng(7))
    calls = []

    def scalar(x):
        calls.append(x.shape)
        return float(target(x))

    one_at_a_time = sampler.sample(scalar, MEAN, np.ones(3), np.random.default_rng(7))
    np.testing.assert_array_equal(batched, one_at_a_time)
    assert set(calls) == {(3,)}


def test_same_seed_same_draws_and_the_support_is_respected():
    def half_space(x):
        x = np.asarray(x)
        return np.where(x[..., 0] > 9.5, Gaussian()(x), -np.inf)

    half_space.vectorized = True
    sampler = IndependenceSampler(n_chains=2, n_draws=300)
    first = sampler.sample(half_space, MEAN + 1.0, np.ones(3), np.random.default_rng(3))
    second = sampler.sample(half_space, MEAN + 1.0, np.ones(3), np.random.default_rng(3))
    np.testing.assert_array_equal(first, second)
    assert first[..., 0].min() > 9.5


def test_a_start_outside_the_support_is_refused():
    with pytest.raises(ValueError, match="not finite at the starting point"):
        IndependenceSampler().sample(lambda x: -math.inf, MEAN, np.ones(3), np.random.default_rng(0))


def test_evaluate_batches_only_vectorized_densities():
    points = np.stack([MEAN, MEAN + 1.0])
    np.testing.assert_allclose(evaluate(Gaussian(), points), [0.0, Gaussian()(MEAN + 1.0)])
    np.testing.assert_allclose(evaluate(lambda x: float(x.sum()), points), points.sum(axis=1))


def test_describe_names_the_settings():
    text = IndependenceSampler(n_chains=3, n_tune=10, n_draws=20).describe(8)
    assert "Student-t" in text and "3 chains of 10 tuning + 20 kept steps" in text
