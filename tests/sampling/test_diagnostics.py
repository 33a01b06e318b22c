import math

import arviz as az
import numpy as np
import pytest

from bayescal.sampling.diagnostics import ess_bulk, ess_tail, rhat


def _ar1(rng, phi, shape):
    noise = rng.standard_normal(shape)
    x = np.zeros(shape)
    for t in range(1, shape[1]):
        x[:, t] = phi * x[:, t - 1] + noise[:, t]
    return x


def _cases():
    rng = np.random.default_rng(1)
    return {
        "independent": rng.standard_normal((4, 1000)),
        "autocorrelated, odd length": _ar1(rng, 0.9, (4, 1001)),
        "ties, as rejected proposals leave": np.round(rng.standard_normal((4, 500)), 1),
        "chains apart": rng.standard_normal((3, 200)) + 0.3 * np.arange(3)[:, None],
        "heavy tails, two chains": rng.standard_t(2, (2, 333)),
    }


@pytest.mark.parametrize("name", list(_cases()))
def test_agrees_with_arviz(name):
    draws = _cases()[name]
    assert rhat(draws) == pytest.approx(float(az.rhat(draws)), rel=1e-12)
    assert ess_bulk(draws) == pytest.approx(float(az.ess(draws, method="bulk")), rel=1e-12)
    assert ess_tail(draws) == pytest.approx(float(az.ess(draws, method="tail", prob=0.05)), rel=1e-12)


def test_undefined_cases_are_nan_and_constant_chains_count_fully():
    rng = np.random.default_rng(0)
    assert math.isnan(rhat(rng.standard_normal((1, 100))))
    assert math.isnan(ess_bulk(rng.standard_normal((4, 3))))
    assert math.isnan(ess_tail(np.full((2, 10), np.nan)))
    assert ess_bulk(np.ones((2, 50))) == 100


def test_diagnose_gives_the_three_diagnostics_at_once():
    from bayescal.sampling.diagnostics import diagnose

    rng = np.random.default_rng(4)
    draws = np.cumsum(rng.normal(size=(4, 300)), axis=1) * 0.1 + rng.normal(size=(4, 300))
    draws[:, ::7] = draws[:, 3:4]  # ties
    assert diagnose(draws) == (rhat(draws), ess_bulk(draws), ess_tail(draws))
    assert np.isnan(diagnose(draws[:1])[0]) and diagnose(draws[:1])[1] == ess_bulk(draws[:1])
