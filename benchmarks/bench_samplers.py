"""Effective samples per second of an elastostatic calibration: the Gibbs sampler against emcee.

Both runs fit the same Table III campaign simulated on the digital twin
(seed 1) with the same model (the exact model, compensator geometry from the
cell's Table II prior), one after the other in this process; only the sampler
differs.  Wall time is the whole ``fit`` (equations, relinearisation,
sampling, summaries); ESS is ArviZ's bulk ESS of every reported parameter
over all chains, and the figure of merit is the smallest ESS divided by the
wall time.  The campaign is then repeated with 10 times as many rows (the
same configurations measured 30 times) to show how the cost grows with the
number of equations.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.inference.elastostatic import ElastostaticModel, default_sampler
from bayescal.twin.simulator import DigitalTwin

DATA = Path(__file__).resolve().parents[1] / "data"


def fit(cell, campaign, sampler: str) -> tuple[float, float, str]:
    model = ElastostaticModel.from_cell(cell, sampler=default_sampler(sampler))
    began = time.perf_counter()
    results = model.fit(campaign, 0)
    seconds = time.perf_counter() - began
    summary = results.summary()
    ess = summary["ess_bulk"].drop([n for n in summary.index if n.startswith("sigma")])
    return seconds, float(ess.min()), str(ess.idxmin())


def main() -> None:
    warnings.simplefilter("ignore")
    cell = load_cell(DATA / "kr270.toml")
    plan = read_plan(DATA / "table3_plan.csv", cell.robot)
    rates = {}
    for repeats in (3, 30):
        campaign = DigitalTwin(cell).simulate(plan, repeats, np.random.default_rng(1))
        for sampler in ("gibbs", "emcee") if repeats == 3 else ("gibbs",):
            seconds, ess, worst = fit(cell, campaign, sampler)
            rates[sampler, repeats] = ess / seconds
            print(
                f"{sampler:<6} {campaign.n_equations:6d} equations  fit {seconds:6.2f} s  "
                f"min bulk ESS {ess:6.0f} ({worst})  ESS/s {ess / seconds:7.1f}"
            )
    print(f"Gibbs / emcee min-ESS per second on the Table III campaign: {rates['gibbs', 3] / rates['emcee', 3]:.1f}")


if __name__ == "__main__":
    main()
