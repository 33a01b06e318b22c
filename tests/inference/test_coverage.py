"""Frequentist coverage of the posterior intervals: truth drawn from a prior, data simulated, intervals checked.

The fast tests use linear-Gaussian problems and, loosely, a few Table III
campaigns on the digital twin; the slow ones simulate many Table III campaigns
on the twin (nonlinear, distance-dependent tracker noise) with parameters drawn
around Table IV and identify them with the exact model.
"""

from pathlib import Path
import dataclasses
import warnings


import numpy as np
import pytest
from scipy import stats

from bayescal.sampling.gibbs import GibbsSampler
from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.likelihood import per_angle_posterior
from bayescal.sampling.ensemble import EnsembleSampler

DATA = Path(__file__).resolve().parents[2] / "data"

LEVELS = np.array([1.0, 2.0, 3.0])
NOMINAL = 2 * stats.norm.cdf(LEVELS) - 1  # 0.6827, 0.9545, 0.9973


def assert_nominal(hits: np.ndarray) -> None:
    """``hits``: (checks, 3) booleans for ±1σ, ±2σ, ±3σ; rates within 4 binomial sd (+1/N) of nominal."""
    n = hits.shape[0]
    rates = hits.mean(axis=0)
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / n) + 1.0 / n
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL, tolerance)


def covered(draws: np.ndarray, truth: np.ndarray) -> np.ndarray:
    mean, sd = draws.mean(axis=0), draws.std(axis=0, ddof=1)
    return np.abs(truth - mean)[:, None] <= LEVELS[None, :] * sd[:, None]


def random_problem(rng, n=60, p=4):
    truth = rng.uniform(1.0, 4.0, p)
    sigma = rng.uniform(0.2, 1.0, 3)
    design = rng.normal(size=(n, p))
    group = np.arange(n) % 3
    y = design @ truth + rng.normal(size=n) * sigma[group]
    columns = np.zeros((n, 6))
    columns[:, [0, 2, 3, 4][:p]] = design
    equations = DeflectionEquations(
        y=y, design=columns, angle=np.zeros(n, dtype=int), q2=np.zeros(1), group=group, group_names=("x", "y", "z")
    )
    free = np.zeros(6, dtype=bool)
    free[[0, 2, 3, 4][:p]] = True
    return per_angle_posterior(equations, free), truth


def test_gibbs_intervals_cover_at_nominal_rates():
    rng = np.random.default_rng(11)
    sampler = GibbsSampler(n_chains=1, n_tune=50, n_draws=800)
    hits = []
    for _ in range(150):
        posterior, truth = random_problem(rng)
        start = np.concatenate([np.linalg.lstsq(posterior.X, posterior.y, rcond=None)[0], np.log([0.5] * 3)])
        draws = sampler.sample(posterior, start, np.full(start.size, 0.05), rng)[0, :, : truth.size]
        hits.append(covered(draws, truth))
    assert_nominal(np.concatenate(hits))


def test_emcee_intervals_cover_at_nominal_rates():
    rng = np.random.default_rng(12)
    sampler = EnsembleSampler(n_chains=1, n_walkers=16, n_tune=300, n_draws=150)
    hits = []
    for _ in range(40):
        posterior, truth = random_problem(rng, p=3)
        start = np.concatenate([np.linalg.lstsq(posterior.X, posterior.y, rcond=None)[0], np.log([0.5] * 3)])
        draws = sampler.sample(posterior, start, np.full(6, 0.05), rng)[0, :, :3]
        hits.append(covered(draws, truth))
    assert_nominal(np.concatenate(hits))


def assert_plausible(hits: np.ndarray) -> None:
    """Loose check for few campaigns: each level's hit count inside the central 99.9 % of its binomial distribution.

    Checks from one campaign are correlated, so only a gross miscalibration (for
    instance sds off by a factor 1.5) is expected to fail it.
    """
    n = hits.shape[0]
    count = hits.sum(axis=0)
    low, high = stats.binom.ppf(0.0005, n, NOMINAL), stats.binom.ppf(0.9995, n, NOMINAL)
    assert np.all((low <= count) & (count <= high)), (count, low, high)


def twin_coverage(sampler: str, campaigns: int, seed: int, sizes: dict | None = None) -> np.ndarray:
    from bayescal.cell.config import load_cell
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.cell.plan import read_plan
    from bayescal.twin.simulator import DigitalTwin
    from bayescal.units import MM, N_PER_MM, URAD_PER_NM

    cell = load_cell(DATA / "kr270.toml")
    plan = read_plan(DATA / "table3_plan.csv", cell.robot)
    rng = np.random.default_rng(seed)
    sizes = sizes or dict(n_chains=4, n_tune=300, n_draws=400)
    samplers = {"gibbs": GibbsSampler(**sizes), "emcee": EnsembleSampler(n_chains=sizes["n_chains"], n_tune=1000, n_draws=max(sizes["n_draws"] // 4, 1))}
    model = ElastostaticModel.from_cell(cell, sampler=samplers[sampler])
    hits = []
    for _ in range(campaigns):
        compliances = cell.compliances * rng.uniform(0.9, 1.1, 6)
        spring = cell.compensator.K_c * rng.uniform(0.7, 1.3), cell.compensator.s0 * rng.uniform(0.95, 1.05)
        truth_cell = dataclasses.replace(cell, compliances=compliances, compensator=cell.compensator.geometry.with_spring(*spring))
        campaign = DigitalTwin(truth_cell).simulate(plan, 3, rng)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            results = model.fit(campaign, rng)
        # The posterior summary, not parameters(): K_c and s0 are reported as not identifiable
        # from these data, but their intervals must still be honest.
        summary = results.summary()
        truth = {f"k{j + 1}": compliances[j] / URAD_PER_NM for j in range(1, 6)}
        truth |= {"K_c": spring[0] / N_PER_MM, "s0": spring[1] / MM}
        for name, value in truth.items():
            hits.append(np.abs(value - summary.loc[name, "mean"]) <= LEVELS * summary.loc[name, "sd"])
    return np.array(hits)


def test_exact_model_gibbs_intervals_are_not_grossly_miscalibrated_on_twin_campaigns():
    # 10 nonlinear twin campaigns, 7 parameters each (k2..k6, K_c, s0) pooled.
    hits = twin_coverage("gibbs", 10, 31, dict(n_chains=2, n_tune=150, n_draws=300))
    assert hits.shape == (70, 3)
    assert_plausible(hits)


@pytest.mark.slow
def test_exact_model_gibbs_coverage_on_twin_campaigns():
    assert_nominal(twin_coverage("gibbs", 40, 21))


@pytest.mark.slow
def test_exact_model_emcee_coverage_on_twin_campaigns():
    assert_nominal(twin_coverage("emcee", 15, 22))
