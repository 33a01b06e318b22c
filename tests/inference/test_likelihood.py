"""Tests of bayescal.inference.likelihood: the elastostatic log-posteriors against their formulas."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.likelihood import CompensatorBlock, compensated_posterior, per_angle_posterior
from bayescal.inference.priors import GeometryPrior
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.units import DEG, MM, N_PER_MM

GEOMETRY = CompensatorGeometry(184.72 * MM, 685.93 * MM, 120.30 * MM, 2.0 * DEG)
"""A compensator of Table II's size (L, a_x, a_y; phi an estimate)."""
Q2 = np.array([-60.0, -30.0, 0.0, 30.0]) * DEG


def _equations(rng, n_per_angle: int = 6, joint: int | None = 1) -> DeflectionEquations:
    m = Q2.size if joint is not None else 1
    n = 3 * n_per_angle * m
    return DeflectionEquations(
        y=rng.normal(0.0, 1e-4, n),
        design=rng.normal(0.0, 50.0, (n, 3)),
        angle=np.repeat(np.arange(m), 3 * n_per_angle),
        compensated_angles=Q2 if joint is not None else np.zeros(0),
        group=np.tile(np.arange(3), n // 3),
        group_names=("x", "y", "z"),
        joint=joint,
    )


def _gaussian(y, fit, group, log_sigma) -> float:
    """Log-likelihood with one sd per group, plus the Jeffreys prior of each sd (flat in log sigma)."""
    sigma = np.exp(log_sigma)[group]
    return float(np.sum(-np.log(sigma) - 0.5 * ((y - fit) / sigma) ** 2))


def test_the_per_angle_density_is_the_gaussian_likelihood_of_eq_30():
    rng = np.random.default_rng(1)
    equations = _equations(rng)
    free = np.ones(equations.per_angle_design().shape[1], dtype=bool)
    posterior = per_angle_posterior(equations, free)
    for _ in range(3):
        k = rng.uniform(1e-7, 1e-6, free.sum())
        log_sigma = rng.normal(np.log(1e-4), 0.3, 3)
        theta = np.concatenate([k, log_sigma])
        expected = _gaussian(equations.y, equations.per_angle_design() @ k, equations.group, log_sigma)
        assert posterior(theta) == pytest.approx(expected, rel=1e-12)
    # Compliances are positive: the flat prior lives on the positive half-line.
    assert posterior(np.concatenate([-k, log_sigma])) == -np.inf


def test_the_density_peaks_at_the_least_squares_compliances():
    rng = np.random.default_rng(2)
    equations = _equations(rng)
    X = equations.per_angle_design()
    truth = rng.uniform(2e-7, 1e-6, X.shape[1])
    equations = replace(equations, y=X @ truth + rng.normal(0.0, 1e-6, X.shape[0]))
    posterior = per_angle_posterior(equations, np.ones(X.shape[1], dtype=bool))
    k_hat = np.linalg.lstsq(X, equations.y, rcond=None)[0]
    log_sigma = np.full(3, np.log(1e-6))
    theta = np.concatenate([k_hat, log_sigma])
    # Central differences of the log density along each compliance: zero at the least-squares point,
    # X'(y - X k) / sigma^2 away from it.
    step = 1e-10
    gradient = [(posterior(theta + step * e) - posterior(theta - step * e)) / (2 * step) for e in np.eye(theta.size)[: X.shape[1]]]
    scale = np.abs(X.T @ X @ k_hat).max() / 1e-12
    assert np.max(np.abs(gradient)) < 1e-6 * scale
    moved = theta.copy()
    moved[0] += 5e-8
    analytic = X.T @ (equations.y - X @ moved[: X.shape[1]]) / 1e-12
    numeric = [(posterior(moved + step * e) - posterior(moved - step * e)) / (2 * step) for e in np.eye(theta.size)[: X.shape[1]]]
    np.testing.assert_allclose(numeric, analytic, rtol=1e-5)


def test_the_compensator_block_gives_eq_8s_compliance_at_each_angle():
    prior = GeometryPrior(mean=np.array([GEOMETRY.L, GEOMETRY.a_x, GEOMETRY.a_y, GEOMETRY.phi]), cov=np.zeros((4, 4)))
    block = CompensatorBlock(Q2, prior, q_ref=float(np.median(Q2)))
    K0, K_c, s0 = 2.0e6, 144 * N_PER_MM, 458 * MM
    z = block.coordinates(np.array([K0, K_c, s0]))
    compliance, log_prior = block.evaluate(z[None])
    expected = GEOMETRY.with_spring(K_c, s0).equivalent_compliance(Q2, 1.0 / K0)
    np.testing.assert_allclose(compliance[0], expected, rtol=1e-10)
    np.testing.assert_allclose(block.spring(z[None])[0], [K0, K_c, s0], rtol=1e-10)
    # The log prior is the Jacobian of K_c's flat prior in log K_c.
    assert log_prior[0] == pytest.approx(np.log(K_c))


@pytest.mark.parametrize("s0", [-1 * MM, 2000 * MM])
def test_the_spring_length_outside_zero_to_a_plus_l_has_no_density(s0):
    prior = GeometryPrior(mean=np.array([GEOMETRY.L, GEOMETRY.a_x, GEOMETRY.a_y, GEOMETRY.phi]), cov=np.zeros((4, 4)))
    block = CompensatorBlock(Q2, prior, q_ref=0.0)
    assert GEOMETRY.L + np.hypot(GEOMETRY.a_x, GEOMETRY.a_y) < 2000 * MM
    z = block.coordinates(np.array([2.0e6, 144 * N_PER_MM, 458 * MM]))
    z[2] = s0
    _, log_prior = block.evaluate(z[None])
    assert log_prior[0] == -np.inf


def test_the_compensated_density_is_the_likelihood_with_eq_8s_joint_2():
    rng = np.random.default_rng(3)
    equations = _equations(rng)
    prior = GeometryPrior(mean=np.array([GEOMETRY.L, GEOMETRY.a_x, GEOMETRY.a_y, GEOMETRY.phi]), cov=np.zeros((4, 4)))
    posterior = compensated_posterior(equations, (0, 2), prior)
    K0, K_c, s0 = 2.0e6, 144 * N_PER_MM, 458 * MM
    k = np.array([4e-7, 6e-7])
    log_sigma = np.log([1e-4, 2e-4, 1.5e-4])
    z = posterior.block.coordinates(np.array([K0, K_c, s0]))
    k2 = GEOMETRY.with_spring(K_c, s0).equivalent_compliance(Q2, 1.0 / K0)
    fit = equations.design[:, [0, 2]] @ k + equations.design[:, 1] * k2[equations.angle]
    expected = _gaussian(equations.y, fit, equations.group, log_sigma) + np.log(K_c)
    assert posterior(np.concatenate([k, z, log_sigma])) == pytest.approx(expected, rel=1e-10)
    with pytest.raises(ValueError, match="compensated joint"):
        compensated_posterior(equations, (0, 1), prior)
