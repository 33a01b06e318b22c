"""The one-sample two-sided Kolmogorov-Smirnov test against the uniform distribution, without ``scipy.stats``.

The LOO-PIT check needs the statistic ``D_n`` of ``n`` values and its survival function
``P(D_n ≥ d)``.  ``scipy.stats`` has it (``kstwo``), but its import alone (0.28 s of CPU beyond
the ``scipy.special`` the critique loads anyway) was a fifth of the ``critique`` command.  The
distribution is computed here from ``scipy.special`` and the published methods:

* ``d ≥ 1/2``: the statistic exceeds ``d`` above and below the diagonal never both at once,
  so ``P = 2 S_n(d)`` exactly, ``S_n`` the one-sided Smirnov survival function
  (``scipy.special.smirnov``);
* where ``2 S_n(d)`` is below :data:`MILLER_BELOW`: ``2 S_n(d)`` (Miller 1956), whose error, the
  chance of both exceedances, is of the order of its square, far below the rounding of one minus a
  CDF near one;
* otherwise, while Durbin's matrix has at most :data:`MATRIX_LIMIT` rows: exact, one minus the CDF
  by the matrix of Marsaglia, Tsang and Wang (2003), "Evaluating Kolmogorov's distribution",
  J. Stat. Softw. 8(18);
* beyond (``n d`` above 150: about 12,000 values and more): Stephens' (1970) approximation,
  the limiting Kolmogorov survival function (``scipy.special.kolmogorov``) at
  ``(√n + 0.12 + 0.11/√n) d``.

``tests/critique/test_kolmogorov.py`` checks each regime against ``scipy.stats.kstwo``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = ["ks_uniform", "kolmogorov_sf"]

MILLER_BELOW = 1e-6
"""Below this, twice the one-sided survival function is the two-sided one to a relative ~1e-6 (the
overlap of the two tails), better than one minus an exact CDF computed in double precision."""

MATRIX_LIMIT = 301
"""Largest Durbin matrix (``2⌈n d⌉ - 1`` rows) evaluated exactly: 299 rows took 0.09 s (repeated
squaring, ``log2 n`` products; 779 rows took 1.7 s).  Larger ones come, at p-values that matter, with
``n`` above about 12,000 values, where Stephens' approximation was within 1.3e-3 of ``kstwo``
(n = 12,000 to 200,000; the tests check it)."""


def ks_uniform(values: np.ndarray) -> tuple[float, float]:
    """Kolmogorov-Smirnov statistic of ``values`` ``(n,)`` in [0, 1] against the uniform distribution, and its p-value.

    The statistic is ``scipy.stats.kstest(values, "uniform")``'s; the p-value is exact
    where :func:`kolmogorov_sf` is.
    """
    x = np.sort(np.clip(np.asarray(values, dtype=float), 0.0, 1.0))
    n = x.size
    statistic = max((np.arange(1.0, n + 1) / n - x).max(), (x - np.arange(0.0, n) / n).max())
    return float(statistic), kolmogorov_sf(n, float(statistic))


def kolmogorov_sf(n: int, d: float) -> float:
    """``P(D_n ≥ d)`` for the two-sided one-sample Kolmogorov-Smirnov statistic of ``n`` values (NaN for a NaN ``d``)."""
    if math.isnan(d):
        return math.nan
    if d >= 1.0:
        return 0.0
    if n * d <= 0.5:
        return 1.0
    one_sided = 2.0 * float(special.smirnov(n, d))
    if d >= 0.5 or one_sided < MILLER_BELOW:
        return min(one_sided, 1.0)
    if 2 * math.ceil(n * d) - 1 <= MATRIX_LIMIT:
        return min(max(1.0 - _durbin_cdf(n, d), 0.0), 1.0)
    root = math.sqrt(n)
    return float(special.kolmogorov((root + 0.12 + 0.11 / root) * d))


def _durbin_cdf(n: int, d: float) -> float:
    """``P(D_n < d)``: ``n!/nⁿ`` times the middle element of ``Hⁿ``, with ``n d = k - h`` and ``H`` the
    ``(2k-1) × (2k-1)`` matrix of Marsaglia, Tsang and Wang (2003), their eq. 2."""
    k = math.ceil(n * d)
    h, m = k - n * d, 2 * k - 1
    rows = np.arange(m)
    order = rows[:, None] - rows[None, :] + 1  # H[i, j] = 1/(i - j + 1)! where i - j + 1 ≥ 0
    H = np.where(order >= 0, np.exp(-special.gammaln(np.maximum(order, 0) + 1.0)), 0.0)
    corner = h ** np.arange(1, m + 1) * np.exp(-special.gammaln(np.arange(2, m + 2)))  # h^i / i!, i = 1..m
    H[:, 0] -= corner
    H[-1, :] -= corner[::-1]
    if 2 * h > 1:
        H[-1, 0] += (2 * h - 1) ** m * math.exp(-special.gammaln(m + 1))
    power, log_scale = _scaled_power(H, n)
    middle = power[k - 1, k - 1]
    if middle <= 0.0:
        return 0.0
    return math.exp(math.log(middle) + log_scale + special.gammaln(n + 1) - n * math.log(n))


def _scaled_power(matrix: np.ndarray, exponent: int) -> tuple[np.ndarray, float]:
    """``matrix**exponent`` as ``(M, s)`` with the power ``M·e^s``: repeated squaring, each product rescaled
    by its largest element so that powers of a few hundred stay within double range."""
    result, result_log = None, 0.0
    base, base_log = matrix, 0.0
    while True:
        if exponent & 1:
            result = base.copy() if result is None else result @ base
            result_log += base_log
            largest = np.abs(result).max()
            result, result_log = result / largest, result_log + math.log(largest)
        exponent >>= 1
        if not exponent:
            return result, result_log
        base = base @ base
        largest = np.abs(base).max()
        base, base_log = base / largest, 2 * base_log + math.log(largest)
