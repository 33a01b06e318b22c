"""The LOO-PIT's Kolmogorov-Smirnov test against SciPy's (``scipy.stats.kstest`` and ``kstwo``) in each regime."""

import math
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from bayescal.critique.kolmogorov import kolmogorov_sf, ks_uniform

EXACT_AGREEMENT = 1e-12
"""Absolute difference allowed where SciPy's ``kstwo`` is exact too (n ≤ 140): measured at most 1.7e-13, the rounding
of one minus a CDF near one."""

PELZ_GOOD_AGREEMENT = 5e-6
"""Absolute difference allowed for 140 < n where ``kstwo`` switches to Pelz and Good's asymptotic series and this
module stays exact: measured at most 2.4e-6 (n = 141), 3.3e-7 at the demo's n = 405."""

STEPHENS_AGREEMENT = 2e-3
"""Absolute difference allowed in Stephens' regime (n d beyond the matrix limit): measured at most 1.3e-3."""


@pytest.mark.parametrize("n", [1, 2, 3, 10, 45, 139, 140])
def test_survival_function_is_exact_where_scipy_is(n):
    for d in np.linspace(0.0005, 0.999, 200):
        assert kolmogorov_sf(n, d) == pytest.approx(float(stats.kstwo.sf(d, n)), rel=0, abs=EXACT_AGREEMENT), (n, d)


@pytest.mark.parametrize("n", [141, 405, 1000, 5000])
def test_survival_function_agrees_with_scipys_asymptotic_series(n):
    for d in np.linspace(0.0005, 0.999, 200):
        assert kolmogorov_sf(n, d) == pytest.approx(float(stats.kstwo.sf(d, n)), rel=0, abs=PELZ_GOOD_AGREEMENT), (n, d)


@pytest.mark.parametrize("n", [20_000, 200_000])
def test_stephens_regime_is_close(n):
    root = math.sqrt(n)
    for d in np.linspace(0.3 / root, 3 / root, 60):
        assert kolmogorov_sf(n, d) == pytest.approx(float(stats.kstwo.sf(d, n)), rel=0, abs=STEPHENS_AGREEMENT), (n, d)


def test_tails_are_twice_the_one_sided_survival():
    # above d = 1/2 the two one-sided exceedances exclude each other: exact in closed form for n d ≥ n - 1
    for n in (3, 10, 405):
        d = 1.0 - 0.6 / n
        assert kolmogorov_sf(n, d) == pytest.approx(2 * (1 - d) ** n, rel=1e-12)


def test_statistic_and_p_value_are_kstests():
    rng = np.random.default_rng(3)
    for n, power in ((405, 1.0), (405, 1.2), (45, 1.5), (2_000, 1.1)):
        values = rng.uniform(size=n) ** power
        expected = stats.kstest(values, "uniform")
        statistic, p_value = ks_uniform(values)
        assert statistic == expected.statistic
        assert p_value == pytest.approx(expected.pvalue, rel=0, abs=PELZ_GOOD_AGREEMENT)


def test_the_critique_loads_without_scipy_stats():
    # scipy.stats was a fifth of the command's CPU (0.28 s to import) for this p-value alone
    code = "import sys, bayescal.critique, bayescal.critique.checks; print('scipy.stats' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"
