"""Effective samples per second of an elastostatic calibration: the Gibbs sampler against emcee.

Both runs fit the same Table III campaign simulated on the digital twin
(seed 1) with the same model (the exact model, compensator geometry from the
cell's Table II prior), one after the other in this process; only the sampler
differs.  Wall time is the whole ``fit`` (equations, relinearisation,
sampling, summaries); ESS is ArviZ's bulk ESS of every reported parameter
over all chains, and the figure of merit is the smallest ESS divided by the
CPU time of this process (steadier than wall time on a shared machine).  The
campaign is then repeated with 10 times as many rows (the same configurations
measured 30 times) to show how the cost grows with the number of equations.
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


def fit(cell, campaign, sampler: str) -> tuple[float, float, float, str]:
    model = ElastostaticModel.from_cell(cell, sampler=default_sampler(sampler))
    began, cpu = time.perf_counter(), time.process_time()
    results = model.fit(campaign, 0)
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    summary = results.summary()
    ess = summary["ess_bulk"].drop([n for n in summary.index if n.startswith("sigma")])
    return seconds, cpu, float(ess.min()), str(ess.idxmin())


def main() -> None:
    warnings.simplefilter("ignore")
    cell = load_cell(DATA / "kr270.toml")
    plan = read_plan(DATA / "table3_plan.csv", cell.robot)
    rates = {}
    for repeats in (3, 30):
        campaign = DigitalTwin(cell).simulate(plan, repeats, np.random.default_rng(1))
        for sampler in ("gibbs", "emcee") if repeats == 3 else ("gibbs",):
            seconds, cpu, ess, worst = fit(cell, campaign, sampler)
            rates[sampler, repeats] = ess / cpu
            print(
                f"{sampler:<6} {campaign.n_equations:6d} equations  fit {seconds:6.2f} s wall, {cpu:6.2f} s CPU  "
                f"min bulk ESS {ess:6.0f} ({worst})  ESS per CPU second {ess / cpu:7.1f}"
            )
    print(f"Gibbs / emcee min-ESS per CPU second on the Table III campaign: {rates['gibbs', 3] / rates['emcee', 3]:.1f}")


if __name__ == "__main__":
    main()
