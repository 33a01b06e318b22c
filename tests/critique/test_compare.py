import numpy as np
import pytest
from scipy import stats

from bayescal.critique.compare import compare, cross_validate, fit


def _linear_data(rng, n_configs=12, per_config=9, levels=(1.0, 2.0, 0.5)):
    X = rng.normal(size=(n_configs * per_config, 3))
    group = np.tile(np.arange(3), n_configs * per_config // 3)
    scale = rng.uniform(0.8, 1.2, size=len(X))
    y = X @ np.array([1.0, -2.0, 0.5]) + rng.normal(size=len(X)) * scale * np.array(levels)[group]
    config = np.repeat(np.arange(n_configs), per_config)
    return y, X, scale, group, config


def test_gaussian_predictive_density_is_the_multivariate_t():
    rng = np.random.default_rng(1)
    y, X, scale, group, _ = _linear_data(rng)
    model = fit(y[9:], X[9:], scale[9:], group[9:])
    covariance = np.diag((model.level[group[:9]] * scale[:9]) ** 2) + X[:9] @ model.cov @ X[:9].T
    expected = stats.multivariate_t(loc=X[:9] @ model.beta, shape=covariance, df=model.dof).logpdf(y[:9])
    assert model.log_density(y[:9], X[:9], scale[:9], group[:9]) == pytest.approx(expected, rel=1e-10)


def test_fit_recovers_the_axis_noise_levels():
    rng = np.random.default_rng(2)
    y, X, scale, group, _ = _linear_data(rng, n_configs=200)
    model = fit(y, X, scale, group)
    assert model.level / model.level[0] == pytest.approx([1.0, 2.0, 0.5], rel=0.1)
    robust = fit(y, X, scale, group, robust=True)
    assert robust.beta == pytest.approx(model.beta, abs=0.1)


def test_leave_one_configuration_out_pit_is_uniform_for_the_true_model():
    rng = np.random.default_rng(3)
    pit = np.concatenate([cross_validate(*_linear_data(rng)).pit for _ in range(40)])
    assert stats.kstest(pit, "uniform").pvalue > 0.01
    # the central 90 % predictive interval covers 90 % of held-out equations
    assert np.mean((pit > 0.05) & (pit < 0.95)) == pytest.approx(0.90, abs=0.02)


def test_a_useless_column_loses_and_a_missing_one_is_found():
    rng = np.random.default_rng(4)
    y, X, scale, group, config = _linear_data(rng)
    full = cross_validate(y, X, scale, group, config)
    without = cross_validate(y, X[:, :2], scale, group, config)
    padded = cross_validate(y, np.column_stack([X, rng.normal(size=len(y))]), scale, group, config)
    found = compare(without, full)
    assert found.delta_elpd > 2 * found.se and found.n_configs == 12
    assert compare(full, padded).delta_elpd < 0


def test_student_t_noise_wins_only_when_there_are_gross_errors():
    rng = np.random.default_rng(5)
    y, X, scale, group, config = _linear_data(rng)
    gaussian = cross_validate(y, X, scale, group, config)
    assert compare(gaussian, cross_validate(y, X, scale, group, config, robust=True)).delta_elpd < 0
    hit = rng.choice(len(y), size=4, replace=False)
    y[hit] += 30.0
    gaussian = cross_validate(y, X, scale, group, config)
    assert compare(gaussian, cross_validate(y, X, scale, group, config, robust=True)).delta_elpd > 25


def test_compare_elpd_sums_the_differences_with_the_se_of_their_mean():
    from bayescal.critique.compare import compare_elpd

    a = np.array([-3.0, -2.0, -4.0, -1.0])
    b = a + np.array([1.0, 2.0, 0.0, 1.0])
    c = compare_elpd(a, b)
    assert c.delta_elpd == pytest.approx(4.0)
    assert c.se == pytest.approx(np.sqrt(4 * np.var([1.0, 2.0, 0.0, 1.0], ddof=1)))
    assert c.n_configs == 4
