import numpy as np
import pytest
from scipy import stats

from bayescal.critique.compare import chosen, compare, cross_validate, fit, smallest_unexplained_fraction
from bayescal.inference.identifiability import independent_columns


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


@pytest.mark.parametrize("per_unit", [3, 9])
def test_student_t_predictive_density_is_the_product_of_each_units_multivariate_t(per_unit):
    rng = np.random.default_rng(6)
    y, X, scale, group, _ = _linear_data(rng)
    unit = np.arange(len(y)) // per_unit
    model = fit(y[18:], X[18:], scale[18:], group[18:], robust=True, unit=unit[18:])
    yh, Xh = y[:18], X[:18]
    spread = np.sqrt((model.level[group[:18]] * scale[:18]) ** 2 + np.einsum("ij,jk,ik->i", Xh, model.cov, Xh))
    expected = sum(
        stats.multivariate_t(loc=Xh[u] @ model.beta, shape=np.diag(spread[u] ** 2), df=model.dof).logpdf(yh[u])
        for u in (unit[:18] == k for k in np.unique(unit[:18]))
    )
    assert model.log_density(y[:18], X[:18], scale[:18], group[:18], unit[:18]) == pytest.approx(expected, rel=1e-10)
    if per_unit == 3:
        # rows of three equations are the default unit
        assert model.log_density(y[:18], X[:18], scale[:18], group[:18]) == pytest.approx(expected, rel=1e-10)


def test_a_gross_error_in_a_whole_row_is_discounted_as_one():
    rng = np.random.default_rng(7)
    y, X, scale, group, _ = _linear_data(rng, n_configs=40)
    clean = fit(y, X, scale, group)
    y[30:33] += 40.0
    robust = fit(y, X, scale, group, robust=True)
    assert robust.beta == pytest.approx(clean.beta, abs=0.15)
    assert np.abs(fit(y, X, scale, group).beta - clean.beta).max() > 0.15


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


def _fold_by_fold(y, X, scale, group, config):
    """Each fold fitted alone by ``fit`` and scored by its ``Fit``: what ``cross_validate`` batches."""
    elpd, predicted, sd, pit = [], np.empty(y.size), np.empty(y.size), np.empty(y.size)
    for held in np.unique(config):
        out = config == held
        keep = independent_columns(X[~out])
        model = fit(y[~out], X[~out][:, keep], scale[~out], group[~out])
        elpd.append(model.log_density(y[out], X[out][:, keep], scale[out], group[out]))
        predicted[out] = model.predict(X[out][:, keep])
        sd[out] = model.marginal_sd(X[out][:, keep], scale[out], group[out])
        pit[out] = stats.t.cdf((y[out] - predicted[out]) / sd[out], model.dof)
    return np.array(elpd), predicted, sd, pit


@pytest.mark.parametrize("uneven", [False, True], ids=["equal folds", "uneven folds"])
def test_batched_folds_equal_each_fold_fitted_alone(uneven):
    rng = np.random.default_rng(7)
    y, X, scale, group, config = _linear_data(rng)
    if uneven:
        # a configuration of 6 equations, not 9, and a column only the last configuration excites:
        # its fold must drop that column, as fit on the remaining equations would
        keep_rows = ~((config == 3) & (np.arange(len(y)) % 9 >= 6))
        y, X, scale, group, config = y[keep_rows], X[keep_rows], scale[keep_rows], group[keep_rows], config[keep_rows]
        X = np.column_stack([X, np.where(config == config.max(), rng.normal(size=len(y)), 0.0)])
    cv = cross_validate(y, X, scale, group, config)
    elpd, predicted, sd, pit = _fold_by_fold(y, X, scale, group, config)
    assert cv.elpd == pytest.approx(elpd, rel=1e-10)
    assert cv.predicted == pytest.approx(predicted, rel=1e-10)
    assert cv.sd == pytest.approx(sd, rel=1e-10)
    assert cv.pit == pytest.approx(pit, rel=1e-10)


def test_smallest_unexplained_fraction_is_what_gram_schmidt_measures():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(60, 3))
    X[:, 2] = X[:, 0] + 0.01 * X[:, 2]
    fold = np.repeat(np.arange(6), 10)
    fraction = smallest_unexplained_fraction(X, fold, 6)
    for k in range(6):
        rest = X[fold != k]
        q, _ = np.linalg.qr(rest[:, :2])
        column = rest[:, 2]
        expected = np.linalg.norm(column - q @ (q.T @ column)) / np.linalg.norm(column)
        assert fraction[k] == pytest.approx(expected, rel=1e-6)


def test_the_largest_of_several_useless_variants_is_no_gain_once_the_variant_is_integrated_out():
    rng = np.random.default_rng(7)
    largest, mixture = [], []
    for _ in range(30):
        y, X, scale, group, config = _linear_data(rng)
        base = cross_validate(y, X, scale, group, config)
        variants = [cross_validate(y, np.column_stack([X, rng.normal(size=len(y))]), scale, group, config) for _ in range(12)]
        index, cv = chosen(variants)
        largest.append(compare(base, variants[index]).delta_elpd)
        mixture.append(compare(base, cv).delta_elpd)
    # the largest of twelve useless columns' held-out totals looks like a gain (1.1 ± 0.2 nats on these seeds);
    # with each configuration predicted by the columns weighted on the others, it is a small loss (-0.5 ± 0.2)
    assert np.mean(largest) > 0.5 and np.mean(mixture) < 0.0


def test_a_variant_far_ahead_of_the_others_keeps_its_scores():
    rng = np.random.default_rng(8)
    y, X, scale, group, config = _linear_data(rng)
    missing = rng.normal(size=len(y))
    y = y + 2.0 * missing
    variants = [cross_validate(y, np.column_stack([X, column]), scale, group, config)
                for column in [rng.normal(size=len(y)), missing, rng.normal(size=len(y))]]
    index, cv = chosen(variants)
    # the missing column leads the others by 105 nats: the mixture is that column
    assert index == 1 and cv.elpd == pytest.approx(variants[1].elpd, abs=1e-9) and cv.full is variants[1].full
    assert chosen(variants[:1]) == (0, variants[0])
