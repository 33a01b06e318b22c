import numpy as np
import pytest

from bayescal.inference.lack_of_fit import LACK_OF_FIT_LEVEL, f_survival, group_scales, lack_of_fit, replicate_cells


def _regression(rng, n_levels=12, repeats=3, curvature=0.0, scale=None):
    """A straight-line fit to data at ``n_levels`` abscissae, each read ``repeats`` times."""
    x = np.repeat(np.linspace(-1.0, 1.0, n_levels), repeats)
    cells = np.repeat(np.arange(n_levels), repeats)
    sd = np.ones_like(x) if scale is None else scale(x)
    y = 1.0 + 2.0 * x + curvature * x**2 + sd * rng.normal(size=x.size)
    X = np.column_stack([np.ones_like(x), x])
    beta = np.linalg.lstsq(X / sd[:, None], y / sd, rcond=None)[0]
    return y - X @ beta, sd, cells


def test_size_is_nominal_under_the_model():
    rng = np.random.default_rng(0)
    p = np.array([lack_of_fit(*_regression(rng), n_parameters=2).p_value for _ in range(2000)])
    # 2000 draws: binomial sd of a 5 % rate is 0.5 %.
    assert abs(np.mean(p < 0.05) - 0.05) < 0.015
    assert abs(np.mean(p < 0.01) - 0.01) < 0.007


def test_size_holds_with_a_noise_level_that_varies_as_the_scale_says():
    rng = np.random.default_rng(1)
    scale = lambda x: 0.2 + np.abs(x)  # noqa: E731
    p = np.array([lack_of_fit(*_regression(rng, scale=scale), n_parameters=2).p_value for _ in range(2000)])
    assert abs(np.mean(p < 0.05) - 0.05) < 0.015


def _three_directions(rng, n_levels=12, repeats=3, sd=(1.0, 0.35, 0.35)):
    """A straight line in three coordinates of unequal noise, weighted by each coordinate's own pure error."""
    x = np.repeat(np.linspace(-1.0, 1.0, n_levels), repeats)
    direction = np.tile(np.arange(3), x.size)
    cells = 3 * np.repeat(np.repeat(np.arange(n_levels), repeats), 3) + direction
    X = np.zeros((3 * x.size, 6))
    for d in range(3):
        X[direction == d, 2 * d] = 1.0
        X[direction == d, 2 * d + 1] = x
    y = X @ np.arange(1.0, 7.0) + np.asarray(sd)[direction] * rng.normal(size=direction.size)
    scale = group_scales(y, np.ones_like(y), cells, direction)
    beta = np.linalg.lstsq(X / scale[:, None], y / scale, rcond=None)[0]
    return y - X @ beta, scale, cells, direction


def test_size_is_nominal_with_weights_from_each_direction_s_own_pure_error():
    rng = np.random.default_rng(6)
    draws = [_three_directions(rng) for _ in range(2000)]
    grouped = np.array([lack_of_fit(r, s, c, 6, groups=g).p_value for r, s, c, g in draws])
    pooled = np.array([lack_of_fit(r, s, c, 6).p_value for r, s, c, _ in draws])
    assert abs(np.mean(grouped < 0.05) - 0.05) < 0.015
    assert abs(np.mean(grouped < 0.01) - 0.01) < 0.007
    # referred to F(dof_lof, dof_pe) the weights' own error makes the test liberal
    assert np.mean(pooled < 0.05) > np.mean(grouped < 0.05)


def test_group_scales_keep_equal_weights_for_equal_pure_errors():
    cells = np.repeat(np.arange(4), 2)
    values = np.array([0.0, 1.0, 0.0, 1.0, 5.0, 6.0, 2.0, 3.0])
    groups = np.array([0, 0, 1, 1, 0, 0, 1, 1])
    assert np.allclose(group_scales(values, np.ones(8), cells, groups), 1.0)


def test_an_omitted_curvature_is_found():
    rng = np.random.default_rng(2)
    result = lack_of_fit(*_regression(rng, curvature=3.0), n_parameters=2)
    assert result.significant()
    assert result.factor > 2
    assert "lack-of-fit F" in result.describe()
    assert set(result.to_json()) == {"statistic", "p_value", "dof", "factor"}


def test_degrees_of_freedom():
    rng = np.random.default_rng(3)
    result = lack_of_fit(*_regression(rng, n_levels=10, repeats=4), n_parameters=2)
    assert result.dof == (10 - 2, 10 * 3)


def test_no_repeats_no_test():
    rng = np.random.default_rng(4)
    assert lack_of_fit(*_regression(rng, repeats=1), n_parameters=2) is None


def test_cells_are_configuration_marker_and_coordinate():
    config = np.array([1, 1, 1, 1, 2, 2])
    marker = np.array(["M1", "M2", "M1", "M2", "M1", "M1"])
    cells = replicate_cells(config, marker)
    assert cells.shape == (18,)
    assert np.array_equal(cells[0:3], cells[6:9])  # config 1, M1, two repeats
    assert not np.array_equal(cells[0:3], cells[3:6])  # another marker
    assert np.array_equal(cells[12:15], cells[15:18])
    assert len(np.unique(cells)) == 3 * 3


def test_level_is_stricter_than_five_percent():
    assert 0 < LACK_OF_FIT_LEVEL <= 0.05


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_residuals_are_refused(bad):
    rng = np.random.default_rng(5)
    residual, scale, cells = _regression(rng)
    residual[0] = bad
    with pytest.raises(ValueError, match="finite"):
        lack_of_fit(residual, scale, cells, n_parameters=2)


@pytest.mark.parametrize("d1", [1, 2, 7, 155, 90_000])
@pytest.mark.parametrize("d2", [1, 5, 90, 60_000, 200_000])
def test_f_survival_equals_scipy(d1, d2):
    from scipy.special import fdtrc

    for f in (1e-3, 0.5, 1.0, 1.02, 1.5, 4.0, 30.0):
        expected = fdtrc(d1, d2, f)
        # Relative to the value; the lgamma differences in the front factor of DLMF 8.17.22 limit it to about 1e-9.
        assert f_survival(d1, d2, f) == pytest.approx(expected, rel=1e-8, abs=1e-300)
    assert f_survival(d1, d2, 0.0) == 1.0
