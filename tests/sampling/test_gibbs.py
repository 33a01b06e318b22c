import numpy as np
import pytest

from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.likelihood import compensated_posterior, per_angle_posterior
from bayescal.inference.priors import GeometryPrior
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.sampling.gibbs import ConditionallyLinear, GibbsSampler, _positive_gaussian


def linear_problem(rng, n=120, groups=1, sigma=0.5):
    design = rng.normal(size=(n, 6)) * [2.0, 3.0, 1.0, 1.5, 1.0, 2.0]
    truth = np.array([2.0, 3.0, 1.5, 4.0, 2.5, 3.5])
    y = design @ truth + rng.normal(size=n) * sigma
    equations = DeflectionEquations(
        y=y,
        design=design,
        angle=np.zeros(n, dtype=int),
        compensated_angles=np.zeros(1),
        group=np.arange(n) % groups,
        group_names=tuple("xyz"[:groups]),
    )
    return equations, truth


def test_per_angle_gibbs_matches_the_exact_student_t_posterior():
    # One noise group with the Jeffreys prior: the marginal posterior of the
    # coefficients is Student t(n - p) around least squares.
    rng = np.random.default_rng(4)
    equations, truth = linear_problem(rng)
    posterior = per_angle_posterior(equations, np.ones(6, dtype=bool))
    start = np.concatenate([truth, [np.log(0.5)]])
    draws = GibbsSampler(n_chains=2, n_tune=100, n_draws=3000).sample(posterior, start, np.full(7, 0.1), rng)
    flat = draws.reshape(-1, draws.shape[-1])[:, :6]
    X, y = posterior.X, equations.y
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    n, p = X.shape
    s2 = np.sum((y - X @ beta) ** 2) / (n - p)
    sd = np.sqrt(s2 * np.diag(np.linalg.inv(X.T @ X)) * (n - p) / (n - p - 2))
    assert np.all(np.abs(flat.mean(axis=0) - beta) < 5 * sd / np.sqrt(flat.shape[0]))
    assert flat.std(axis=0) == pytest.approx(sd, rel=0.06)


def test_gibbs_refuses_a_plain_log_density():
    with pytest.raises(TypeError, match="ConditionallyLinear"):
        GibbsSampler().sample(lambda theta: 0.0, np.zeros(2), np.ones(2), np.random.default_rng(0))


def test_the_model_is_its_own_log_density():
    rng = np.random.default_rng(1)
    equations, truth = linear_problem(rng, groups=3)
    model = per_angle_posterior(equations, np.ones(6, dtype=bool))
    log_sigma = np.log([0.4, 0.5, 0.6])
    residual = equations.y - equations.design @ truth
    sigma = np.exp(log_sigma)[equations.group]
    expected = float(np.sum(-np.log(sigma) - 0.5 * (residual / sigma) ** 2))
    assert model(np.concatenate([truth, log_sigma])) == pytest.approx(expected)
    assert model(np.concatenate([-truth, log_sigma])) == -np.inf
    assert isinstance(model, ConditionallyLinear)


def test_positive_gaussian_stays_positive_when_rejection_fails():
    rng = np.random.default_rng(0)
    mean = np.array([[-3.0, 1.0], [1.0, 1.0]])
    covariance = np.stack([np.eye(2), np.eye(2)])
    x = np.array([[0.5, 1.0], [1.0, 1.0]])
    for _ in range(50):
        x = _positive_gaussian(mean, covariance, x, rng)
        assert np.all(x > 0)


def compensated_problem(rng, sigma=2e-6):
    deg = np.pi / 180
    geometry = np.array([0.18472, 0.68593, 0.1203, 99.8 * deg])
    q2 = np.array([-0.01, -25.24, -56.9, -99.85, -140.0]) * deg
    compensator = CompensatorGeometry(*geometry).with_spring(1.44e5, 0.458)
    k2 = compensator.equivalent_compliance(q2, 0.302e-6)
    n = 300
    angle = np.arange(n) % 5
    design = rng.normal(size=(n, 6)) * np.array([0.0, 1e4, 3e3, 500, 500, 500])
    truth = np.array([0.0, 0.0, 0.406, 3.0, 3.3, 2.37]) * 1e-6
    y = design @ truth + design[:, 1] * k2[angle] + rng.normal(size=n) * sigma
    equations = DeflectionEquations(y=y, design=design, angle=angle, compensated_angles=q2, group=np.arange(n) % 3, group_names=("x", "y", "z"))
    prior = GeometryPrior(mean=geometry, cov=np.zeros((4, 4)))
    posterior = compensated_posterior(equations, (2, 3, 4, 5), prior)
    z = posterior.block.coordinates(np.array([1 / 0.302e-6, 1.44e5, 0.458]))
    start = np.concatenate([truth[2:], z, np.log(np.full(3, sigma))])
    return posterior, start


def test_block_coordinates_round_trip_to_the_spring():
    posterior, start = compensated_problem(np.random.default_rng(0))
    spring = posterior.block.spring(start[None, 4:7])[0]
    assert spring == pytest.approx([1 / 0.302e-6, 1.44e5, 0.458], rel=1e-12)


# Neither is the default sampler (test_collapsed.py compares the default with Gibbs): a `make test-slow` study.
@pytest.mark.slow
def test_compensated_gibbs_and_emcee_sample_the_same_posterior():
    rng = np.random.default_rng(2)
    posterior, start = compensated_problem(rng)
    scale = np.abs(start) * np.array([1e-3] * 4 + [1e-3, 0.0, 0.01] + [0.0] * 3) + np.array([0.0] * 5 + [0.05, 0.0] + [0.05] * 3)
    gibbs = GibbsSampler(n_chains=2, n_tune=300, n_draws=1500).sample(posterior, start, scale, rng)
    emcee = EnsembleSampler(n_chains=2, n_tune=1500, n_draws=400).sample(posterior, start, scale, rng)
    g = gibbs.reshape(-1, posterior.ndim)
    e = emcee.reshape(-1, posterior.ndim)
    # Every parameter: means within a few Monte-Carlo errors (ESS ~ draws/20 for emcee), sds within 20%.
    for i in range(posterior.ndim):
        sd = g[:, i].std()
        assert abs(g[:, i].mean() - e[:, i].mean()) < 0.25 * sd, i
        assert e[:, i].std() == pytest.approx(sd, rel=0.2), i
