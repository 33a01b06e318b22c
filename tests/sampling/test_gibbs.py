import numpy as np
import pytest

from bayescal.sampling.gibbs import GibbsSampler, _positive_gaussian
from bayescal.inference.likelihood import CompensatedPosterior, DeflectionEquations, GeometryPrior, PerAnglePosterior
from bayescal.sampling.ensemble import EnsembleSampler


def linear_problem(rng, n=120, groups=1, sigma=0.5):
    design = rng.normal(size=(n, 6)) * [2.0, 3.0, 1.0, 1.5, 1.0, 2.0]
    truth = np.array([2.0, 3.0, 1.5, 4.0, 2.5, 3.5])
    y = design @ truth + rng.normal(size=n) * sigma
    equations = DeflectionEquations(
        y=y,
        design=design,
        angle=np.zeros(n, dtype=int),
        q2=np.zeros(1),
        group=np.arange(n) % groups,
        group_names=tuple("xyz"[:groups]),
    )
    return equations, truth


def test_per_angle_gibbs_matches_the_exact_student_t_posterior():
    # One noise group with the Jeffreys prior: the marginal posterior of the
    # coefficients is Student t(n - p) around least squares.
    rng = np.random.default_rng(4)
    equations, _ = linear_problem(rng)
    posterior = PerAnglePosterior(equations, np.ones(6, dtype=bool))
    draws = GibbsSampler(n_chains=2, n_tune=100, n_draws=3000).sample_per_angle(posterior, rng)
    flat = draws.reshape(-1, draws.shape[-1])[:, :6]
    X, y = posterior.design, equations.y
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    n, p = X.shape
    s2 = np.sum((y - X @ beta) ** 2) / (n - p)
    sd = np.sqrt(s2 * np.diag(np.linalg.inv(X.T @ X)) * (n - p) / (n - p - 2))
    assert np.all(np.abs(flat.mean(axis=0) - beta) < 5 * sd / np.sqrt(flat.shape[0]))
    assert flat.std(axis=0) == pytest.approx(sd, rel=0.06)


def test_positive_gaussian_stays_positive_when_rejection_fails():
    rng = np.random.default_rng(0)
    mean = np.array([-3.0, 1.0])
    chol = np.linalg.cholesky(np.eye(2))
    x = np.array([0.5, 1.0])
    for _ in range(50):
        x = _positive_gaussian(mean, chol, x, rng)
        assert np.all(x > 0)


def compensated_problem(rng, sigma=2e-6):
    deg = np.pi / 180
    geometry = np.array([0.18472, 0.68593, 0.1203, 99.8 * deg])
    q2 = np.array([-0.01, -25.24, -56.9, -99.85, -140.0]) * deg
    from bayescal.robot.compensator import CompensatorGeometry

    k2 = 1.0 / CompensatorGeometry(*geometry).with_spring(1.44e5, 0.458).joint_stiffness(q2, 1 / 0.302e-6)
    n = 300
    angle = np.arange(n) % 5
    design = rng.normal(size=(n, 6)) * np.array([0.0, 1e4, 3e3, 500, 500, 500])
    truth = np.array([0.0, 0.0, 0.406, 3.0, 3.3, 2.37]) * 1e-6
    y = design @ truth + design[:, 1] * k2[angle] + rng.normal(size=n) * sigma
    equations = DeflectionEquations(
        y=y, design=design, angle=angle, q2=q2, group=np.arange(n) % 3, group_names=("x", "y", "z")
    )
    prior = GeometryPrior(mean=geometry, cov=np.zeros((4, 4)))
    posterior = CompensatedPosterior(equations, (2, 3, 4, 5), prior)
    start = posterior.start(truth[2:], np.array([1 / 0.302e-6, 1.44e5, 0.458]), np.full(3, sigma))
    return posterior, start


def test_compensated_gibbs_and_emcee_sample_the_same_posterior():
    rng = np.random.default_rng(2)
    posterior, start = compensated_problem(rng)
    gibbs = GibbsSampler(n_chains=2, n_tune=300, n_draws=1500).sample_compensated(posterior, start, rng)
    scale = np.abs(start) * np.array([1e-3] * 4 + [1e-3, 0.05, 0.01] + [0.0] * 3) + np.array([0.0] * 7 + [0.05] * 3)
    emcee = EnsembleSampler(n_chains=2, n_tune=1500, n_draws=400).sample(posterior.log_prob, start, scale, rng)
    g = gibbs.reshape(-1, posterior.ndim)
    e = emcee.reshape(-1, posterior.ndim)
    # Every parameter: means within a few Monte-Carlo errors (ESS ~ draws/20 for emcee), sds within 20%.
    for i, name in enumerate(posterior.names()):
        sd = g[:, i].std()
        assert abs(g[:, i].mean() - e[:, i].mean()) < 0.25 * sd, name
        assert e[:, i].std() == pytest.approx(sd, rel=0.2), name
