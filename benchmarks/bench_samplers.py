"""Effective samples per second of an elastostatic calibration: the default (collapsed) sampler, Gibbs and emcee.

Each campaign is fitted three times in this process, once with each sampler and
otherwise the same model (the exact model, compensator geometry from the
cell's Table II prior): the Table III campaign simulated on the digital twin
(15 configurations, 3 repeats), then campaigns of 10 and 100 times as many
configurations (random plans over the joints' ranges, q2 at 15 angles, 3
repeats), to show how the cost grows with the number of equations.  Wall time
is the whole ``fit`` (equations, relinearisation, sampling, summaries); ESS is
the smaller of ArviZ-style bulk and tail ESS over all chains of every parameter
but the noise levels, and the figure of merit is the smallest ESS divided by
the CPU time of this process (steadier than wall time on a shared machine).
``--quick`` leaves out the 100× campaign.  BLAS runs on one thread: the
matrices here are a few rows wide, and on a loaded machine BLAS threads spin
rather than help (the collapsed sampler took 5-6 s of CPU with them, 1.2 s without).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
import time
import warnings
from pathlib import Path

import numpy as np

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.samplers import elastostatic_sampler
from bayescal_studies.studies.elastostatic_coverage import random_plan
from bayescal.twin.simulator import DigitalTwin
from smoke import SAMPLER, SMOKE

DATA = Path(__file__).resolve().parents[1] / "data"
REPEATS = 3
ANGLES = 15
"""q2 angles of the larger campaigns: Table III's 15 configurations, one angle each, scaled up."""


def fit(cell, campaign, sampler: str) -> tuple[float, float, float, str, float]:
    model = ElastostaticModel.from_cell(cell, sampler=elastostatic_sampler(sampler, **SAMPLER))
    began, cpu = time.perf_counter(), time.process_time()
    results = model.fit(campaign, 0)
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    summary = results.summary()
    ess = summary[["ess_bulk", "ess_tail"]].min(axis=1).drop([n for n in summary.index if n.startswith("sigma")])
    return seconds, cpu, float(ess.min()), str(ess.idxmin()), float(summary["r_hat"].max())


def campaigns(cell, quick: bool):
    table_iii = read_plan(DATA / "table3_plan.csv", cell.robot)
    yield "Table III", DigitalTwin(cell).simulate(table_iii, REPEATS, np.random.default_rng(1))
    for factor in () if SMOKE else (10,) if quick else (10, 100):
        rng = np.random.default_rng(factor)
        plan = random_plan(cell, ANGLES, len(table_iii.q) * factor // ANGLES, rng)
        yield f"{factor}x configurations", DigitalTwin(cell).simulate(plan, REPEATS, rng)


def main(quick: bool) -> None:
    warnings.simplefilter("ignore")
    cell = load_cell(DATA / "kr270.toml")
    for label, campaign in campaigns(cell, quick):
        rates = {}
        for sampler in ("collapsed", "gibbs", "emcee"):
            seconds, cpu, ess, worst, r_hat = fit(cell, campaign, sampler)
            rates[sampler] = ess / cpu
            print(
                f"{label:<20} {sampler:<9} {campaign.n_equations:6d} equations  fit {seconds:6.2f} s wall, {cpu:6.2f} s CPU  "
                f"min bulk/tail ESS {ess:6.0f} ({worst})  R-hat max {r_hat:.4f}  ESS per CPU second {ess / cpu:8.1f}"
            )
        print(
            f"{label:<20} min-ESS per CPU second, collapsed over Gibbs: {rates['collapsed'] / rates['gibbs']:.1f}, "
            f"collapsed over emcee: {rates['collapsed'] / rates['emcee']:.0f}, Gibbs over emcee: {rates['gibbs'] / rates['emcee']:.0f}"
        )


if __name__ == "__main__":
    main(quick="--quick" in sys.argv[1:])
