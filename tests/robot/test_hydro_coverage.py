"""Coverage of the hydro-pneumatic compensator's intervals on simulated campaigns (slow).

Each campaign draws its own truth about the test cell's values, its own random plan and noise,
simulates it on the twin and identifies it with the unchanged cell
(:func:`bayescal_studies.studies.elastostatic_coverage.fit_against_truth`).  At the KR-270's tracker noise the
cylinder changes joint 2's stiffness by about 0.1 %, which no campaign resolves (docs/elastostatic.md);
at 0.3 μm per coordinate F0 and h0 are identified to a few percent (median sd 1.7 % and 2.6 % at seed 46),
and their intervals are checked there.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from bayescal.cell.config import load_cell
from bayescal_studies.studies.elastostatic_coverage import Truth, fit_against_truth
from bayescal.design.parallel import seeded_map

LEVELS = np.array([1.0, 2.0, 3.0])
NOMINAL = 2 * stats.norm.cdf(LEVELS) - 1  # 0.6827, 0.9545, 0.9973
SPREAD = {"compliances": 0.1, "F0": 0.3, "h0": 0.1, "masses": 0.15}
"""Uniform factors ``1 ± spread`` of the drawn truths about the cell's values."""
NOISE_UM = 0.3
"""Tracker noise sd per coordinate (μm) at which the campaigns identify F0 and h0."""


def _one_campaign(index: int, rng: np.random.Generator, *, cell) -> list[dict]:
    factor = lambda width, n=None: rng.uniform(1.0 - width, 1.0 + width, n)  # noqa: E731
    law = cell.compensator
    truth = Truth(
        compliances=cell.compliances * factor(SPREAD["compliances"], cell.robot.nq),
        spring=(law.F0 * factor(SPREAD["F0"]), law.h0 * factor(SPREAD["h0"])),
        masses=factor(SPREAD["masses"]),
    )
    return [{"campaign": index} | row for row in fit_against_truth(cell, truth, rng, size=(6, 5, 3), noise_um=NOISE_UM)]


def hydro_coverage(cell, campaigns: int, seed: int) -> pd.DataFrame:
    """One row per campaign and parameter: truth, posterior mean and sd, z, identifiable (edge units)."""
    rows = seeded_map(_one_campaign, range(campaigns), seed, executor=ThreadPoolExecutor(2), cell=cell)
    return pd.DataFrame([row for campaign in rows for row in campaign])


@pytest.mark.slow
def test_the_cylinders_intervals_cover_at_nominal_rates_on_60_campaigns(data_dir):
    table = hydro_coverage(load_cell(data_dir / "robots" / "kr270_hydro.toml"), 60, 46)
    law = table[table["parameter"].isin(["F0", "h0"])]
    # A random plan may leave the cylinder unresolved (1 of 60 at seed 46): flagged, and counted apart.
    assert len(law) == 120 and law["identifiable"].mean() >= 0.9
    for _, group in law[law["identifiable"]].groupby("parameter"):
        rates = (np.abs(group["z"].to_numpy())[:, None] <= LEVELS).mean(axis=0)
        tolerance = 3 * np.sqrt(NOMINAL * (1 - NOMINAL) / len(group)) + 1.0 / len(group)
        assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, NOMINAL)
