import numpy as np
import pytest

from bayescal.sampling.collapsed import CollapsedSampler, MarginalDensity
from bayescal.sampling.gibbs import GibbsSampler

from tests.inference.test_coverage import assert_nominal, covered, random_problem
from tests.sampling.test_gibbs import compensated_problem

SMALL = CollapsedSampler(n_chains=4, n_draws=400, n_adapt=1000, pilot_chains=8, pilot_sweeps=10)


def test_marginal_density_is_the_joint_over_the_conditional_of_k():
    """log p(x) = log p(k, x) - log N(k; mean(x), P(x)^-1) at any k: the same constant at every x."""
    posterior, start = compensated_problem(np.random.default_rng(5))
    density = MarginalDensity(posterior)
    p = posterior.n_linear
    rng = np.random.default_rng(6)
    constants = []
    for _ in range(4):
        x = start[p:] + rng.normal(size=start.size - p) * np.r_[1e3, 0.2, 0.02, 0.05, 0.05, 0.05]
        value, _, mean, chol = density.conditional(x[None])
        k = mean[0] + rng.normal(size=p) * 1e-9
        u = chol[0].T @ (k - mean[0])
        log_conditional = np.sum(np.log(np.diag(chol[0]))) - 0.5 * u @ u
        constants.append(posterior(np.concatenate([k, x])) - log_conditional - value[0])
    assert np.ptp(constants) < 1e-6 * np.abs(constants[0]) + 1e-6


def test_collapsed_intervals_cover_at_nominal_rates():
    rng = np.random.default_rng(13)
    hits = []
    for _ in range(100):
        posterior, truth = random_problem(rng)
        start = np.concatenate([np.linalg.lstsq(posterior.X, posterior.y, rcond=None)[0], np.log([0.5] * 3)])
        draws = SMALL.sample(posterior, start, np.full(start.size, 0.05), rng)[0, :, : truth.size]
        hits.append(covered(draws, truth))
    assert_nominal(np.concatenate(hits))


def test_collapsed_and_gibbs_sample_the_same_compensated_posterior():
    rng = np.random.default_rng(2)
    posterior, start = compensated_problem(rng)
    scale = np.abs(start) * np.array([1e-3] * 4 + [1e-3, 0.0, 0.01] + [0.0] * 3) + np.array([0.0] * 5 + [0.05, 0.0] + [0.05] * 3)
    gibbs = GibbsSampler(n_chains=4, n_tune=100, n_draws=1000).sample(posterior, start, scale, rng).reshape(-1, posterior.ndim)
    collapsed = CollapsedSampler().sample(posterior, start, scale, rng)
    assert collapsed.shape == (32, 600, posterior.ndim)
    c = collapsed.reshape(-1, posterior.ndim)
    assert np.all(c[:, : posterior.n_linear] > 0)
    for i in range(posterior.ndim):
        sd = gibbs[:, i].std()
        assert abs(gibbs[:, i].mean() - c[:, i].mean()) < 0.15 * sd, i
        assert c[:, i].std() == pytest.approx(sd, rel=0.1), i


def test_collapsed_refuses_a_plain_log_density():
    with pytest.raises(TypeError, match="ConditionallyLinear"):
        SMALL.sample(lambda theta: 0.0, np.zeros(2), np.ones(2), np.random.default_rng(0))
