import numpy as np
import pytest

from bayescal.critique.checks import OUTLIER_Z, residual_summary, standardised_residuals
from bayescal.critique.compare import cross_validate


def test_residual_summary_counts_gross_errors_and_reports_mm():
    rng = np.random.default_rng(0)
    n_configs, per_config = 20, 9
    X = rng.normal(size=(n_configs * per_config, 2))
    group = np.tile(np.arange(3), n_configs * per_config // 3)
    y = (X @ np.array([1.0, 2.0]) + rng.normal(size=len(X))) * 1e-5
    y[[5, 50]] += 1e-3
    cv = cross_validate(y, X * 1e-5, np.ones(len(y)), group, np.repeat(np.arange(n_configs), per_config))
    z = standardised_residuals(y, cv)
    summary = residual_summary(y, cv, np.repeat(np.arange(len(y) // 3), 3))
    assert summary["outliers"] == int(np.sum(np.abs(z) > OUTLIER_Z)) >= 2
    assert summary["residual_rms_mm"] == pytest.approx(np.sqrt(np.mean((y - cv.predicted) ** 2)) * 1e3)
    assert summary["position_error_rms_mm"] == pytest.approx(np.sqrt(3) * summary["residual_rms_mm"])
    assert 0 <= summary["loo_pit"]["p_value"] <= 1
