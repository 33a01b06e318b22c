"""Convergence diagnostics of MCMC draws: rank-normalised split R-hat, bulk and tail ESS.

The definitions are those of Vehtari, Gelman, Simpson, Carpenter and Bürkner
(2021), "Rank-normalization, folding, and localization: an improved R-hat for
assessing convergence of MCMC", as ArviZ computes them (``arviz.rhat`` with
the default ``method="rank"``, ``arviz.ess`` with ``method="bulk"`` and
``"tail"``); the tests check that the values agree with ArviZ's.  They live
here, in NumPy and the standard library, because importing ArviZ's
statistics (and with them ``scipy.stats``) takes about 2 s, longer than a
whole geometry fit.

Every function takes the draws of one scalar quantity, shape ``(chain, draw)``.
"""

from __future__ import annotations

import math
from functools import lru_cache
from statistics import NormalDist

import numpy as np

__all__ = ["rhat", "ess_bulk", "ess_tail", "diagnose"]

_BLOM_OFFSET = 3 / 8
"""Fractional offset of the normal scores of ranks, ``(r - 3/8) / (N + 1/4)`` (Blom, 1958)."""

_TAIL_PROBABILITY = 0.05
"""Tail ESS is the smaller ESS of the indicators of the 5 % and 95 % quantiles (Vehtari et al. 2021)."""

_MIN_DRAWS = 4
"""Fewest draws per chain for which the diagnostics are defined (as ArviZ's)."""


def rhat(draws: np.ndarray) -> float:
    """Rank-normalised split R-hat: the larger of the bulk and the folded (tail) split R-hat.

    Parameters
    ----------
    draws
        Shape ``(chain, draw)``; at least 2 chains and 4 draws, else NaN.
    """
    draws = np.asarray(draws, dtype=float)
    if _invalid(draws) or draws.shape[0] < 2:
        return math.nan
    split = _split_chains(draws)
    folded = np.abs(split - np.median(split))
    return max(_basic_rhat(_z_scale(split)), _basic_rhat(_z_scale(folded)))


def ess_bulk(draws: np.ndarray) -> float:
    """Bulk effective sample size: the ESS of the rank-normalised split chains.

    Parameters
    ----------
    draws
        Shape ``(chain, draw)``; at least 4 draws, else NaN.
    """
    draws = np.asarray(draws, dtype=float)
    if _invalid(draws):
        return math.nan
    return _ess(_z_scale(_split_chains(draws)))


def ess_tail(draws: np.ndarray) -> float:
    """Tail effective sample size: the smaller ESS of the indicators of the 5 % and 95 % quantiles.

    Parameters
    ----------
    draws
        Shape ``(chain, draw)``; at least 4 draws, else NaN.
    """
    draws = np.asarray(draws, dtype=float)
    if _invalid(draws):
        return math.nan
    low, high = np.quantile(draws, [_TAIL_PROBABILITY, 1 - _TAIL_PROBABILITY])
    return min(_ess(_split_chains(draws <= low)), _ess(_split_chains(draws <= high)))


def diagnose(draws: np.ndarray) -> tuple[float, float, float]:
    """:func:`rhat`, :func:`ess_bulk` and :func:`ess_tail` of the same draws, the rank normalisation done once.

    Parameters
    ----------
    draws
        Shape ``(chain, draw)``.
    """
    draws = np.asarray(draws, dtype=float)
    if _invalid(draws):
        return math.nan, math.nan, math.nan
    split = _split_chains(draws)
    z = _z_scale(split)
    bulk = _ess(z)
    if draws.shape[0] < 2:
        r_hat = math.nan
    else:
        r_hat = max(_basic_rhat(z), _basic_rhat(_z_scale(np.abs(split - np.median(split)))))
    return r_hat, bulk, ess_tail(draws)


def _invalid(draws: np.ndarray) -> bool:
    return draws.ndim != 2 or draws.shape[1] < _MIN_DRAWS or not np.all(np.isfinite(draws))


def _split_chains(draws: np.ndarray) -> np.ndarray:
    """Each chain's first and last halves as separate chains (the middle draw of an odd chain is dropped)."""
    half = draws.shape[1] // 2
    return np.vstack([draws[:, :half], draws[:, -half:]]).astype(float)


def _average_ranks(values: np.ndarray) -> np.ndarray:
    """Ranks 1..N of the flattened values, ties given their average rank."""
    flat = values.ravel()
    # Tied values get their group's average rank whatever their order, so the sort need not be stable.
    order = np.argsort(flat)
    ordered = flat[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    ends = np.r_[starts[1:], flat.size]
    group = np.repeat(np.arange(starts.size), ends - starts)
    ranks = np.empty(flat.size)
    ranks[order] = (0.5 * (starts + 1 + ends))[group]
    return ranks.reshape(values.shape)


@lru_cache(maxsize=8)
def _normal_scores(n: int) -> np.ndarray:
    """Normal scores of the half-integer ranks 1, 1.5, …, n (average ranks are integers or half-integers)."""
    ranks = 1 + 0.5 * np.arange(2 * n - 1)
    quantile = NormalDist().inv_cdf
    return np.array([quantile(p) for p in (ranks - _BLOM_OFFSET) / (n - 2 * _BLOM_OFFSET + 1)])


def _z_scale(values: np.ndarray) -> np.ndarray:
    ranks = _average_ranks(values)
    return _normal_scores(values.size)[np.rint(2 * (ranks - 1)).astype(int)]


def _basic_rhat(chains: np.ndarray) -> float:
    n = chains.shape[1]
    between = n * np.var(chains.mean(axis=1), ddof=1)
    within = np.mean(np.var(chains, axis=1, ddof=1))
    return float(np.sqrt((between / within + n - 1) / n))


def _autocovariance(chains: np.ndarray) -> np.ndarray:
    """Autocovariance of each chain at every lag ``(chain, lag)``, by FFT with zero padding."""
    n = chains.shape[1]
    size = 1 << (2 * n - 1).bit_length()
    centred = chains - chains.mean(axis=1, keepdims=True)
    spectrum = np.fft.rfft(centred, n=size, axis=1)
    return np.fft.irfft(spectrum * np.conjugate(spectrum), n=size, axis=1)[:, :n] / n


def _ess(chains: np.ndarray) -> float:
    """ESS of chains ``(chain, draw)`` with Geyer's initial monotone sequence of autocorrelations."""
    chains = np.asarray(chains, dtype=float)
    n_chain, n_draw = chains.shape
    if np.max(chains) - np.min(chains) < np.finfo(float).resolution:
        return float(chains.size)
    acov = _autocovariance(chains)
    mean_acov = acov.mean(axis=0)
    chain_var = mean_acov[0] * n_draw / (n_draw - 1.0)
    var_plus = chain_var * (n_draw - 1.0) / n_draw
    if n_chain > 1:
        var_plus += np.var(chains.mean(axis=1), ddof=1)
    rho = 1.0 - (chain_var - mean_acov) / var_plus
    rho[0] = 1.0
    # Geyer's initial positive sequence: sum pairs (rho_2k + rho_2k+1) while the pair sum is positive.
    kept = np.zeros(n_draw)
    kept[:2] = rho[:2]
    even, odd = rho[0], rho[1]
    t = 1
    while t < n_draw - 3 and even + odd > 0.0:
        even, odd = rho[t + 1], rho[t + 2]
        if even + odd >= 0:
            kept[t + 1], kept[t + 2] = even, odd
        t += 2
    last = t - 2
    if even > 0:
        kept[last + 1] = even
    # Geyer's initial monotone sequence: the pair sums may not increase.
    t = 1
    while t <= last - 2:
        if kept[t + 1] + kept[t + 2] > kept[t - 1] + kept[t]:
            kept[t + 1] = kept[t + 2] = (kept[t - 1] + kept[t]) / 2.0
        t += 2
    size = n_chain * n_draw
    tau = -1.0 + 2.0 * np.sum(kept[: last + 1]) + np.sum(kept[last + 1 : last + 2])
    tau = max(tau, 1 / np.log10(size))
    return float(size / tau)
