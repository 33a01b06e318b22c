"""Effective samples per second of the geometry posterior: the default sampler against emcee.

The posterior is that of ``bayescal geometry data/table1_geometry.csv`` (the
paper's Table I, concentric cylinder markers).  Both samplers run through
``GeometryPosteriorModel.fit`` in this process, one after the other, with
their default settings: the independence Metropolis-Hastings sampler
(:func:`~bayescal.geometry.posterior.geometry_sampler`) and the emcee
ensembles that were the default before it
(:func:`~bayescal.geometry.posterior.geometry_sampler` ``("emcee")``).  The wall time is that
of the whole fit (closed form, sampling, σ draws, summary), with its CPU
time beside it (on a shared machine the CPU time shows what the wall time
would be on an idle one); ESS is the
smallest bulk ESS over the reported parameters.  The two posteriors' means
are compared in units of their combined Monte-Carlo standard error, and the
command line is timed in a fresh interpreter, start-up included.
"""

from __future__ import annotations

import math
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from bayescal.geometry.arcs import read_arc_points
from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
from smoke import SAMPLER

DATA = Path(__file__).resolve().parents[1] / "data" / "table1_geometry.csv"
COMPARED = ("L", "a_x", "a_y", "phi")
SEED = 0


def measure(name, sampler, points):
    """Fit once; print and return the wall time, the min bulk ESS and the summary (and print the CPU time)."""
    began, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = GeometryPosteriorModel(sampler=sampler).fit(points, rng=SEED)
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    d = result.diagnostics()
    print(
        f"{name:<12} {seconds:7.2f} s wall ({cpu:6.2f} s CPU)  {d['n_chains']} chains x {d['n_draws']} draws  "
        f"R-hat max {d['r_hat_max']:.4f}  min bulk ESS {d['ess_bulk_min']:6.0f}  min ESS/s {d['ess_bulk_min'] / seconds:8.1f}"
    )
    return seconds, d["ess_bulk_min"], result.summary(), cpu


def command_line_seconds() -> tuple[float, float]:
    """Wall and CPU (user + system) time of ``bayescal geometry ... --posterior`` in a fresh interpreter.

    The CPU time does not count waiting for a core, so on a shared machine it
    shows what the wall time would be on an idle one.
    """
    with tempfile.TemporaryDirectory() as tmp:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        began = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "bayescal.cli", "geometry", str(DATA), "--posterior", str(Path(tmp) / "posterior.nc")],
            check=True,
            capture_output=True,
        )
        wall = time.perf_counter() - began
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    points = read_arc_points(DATA)
    print(f"posterior: {DATA.name}, concentric cylinder markers, seed {SEED}")
    default = measure("independence", geometry_sampler(**SAMPLER), points)
    previous = measure("emcee", geometry_sampler("emcee", **SAMPLER), points)
    print(
        f"min ESS/s ratio (independence / emcee): {(default[1] / default[0]) / (previous[1] / previous[0]):.0f} by wall time, "
        f"{(default[1] / default[3]) / (previous[1] / previous[3]):.0f} by CPU time"
    )
    print("posterior means, independence - emcee, in units of their combined Monte-Carlo standard error:")
    for name in COMPARED:
        a, b = default[2].loc[name], previous[2].loc[name]
        mcse = math.hypot(a["sd"] / math.sqrt(a["ess_bulk"]), b["sd"] / math.sqrt(b["ess_bulk"]))
        print(
            f"  {name:<4} {a['mean']:11.4f} vs {b['mean']:11.4f} {a['unit']:<3}  ({(a['mean'] - b['mean']) / mcse:+5.2f})   "
            f"sd {a['sd']:.4f} vs {b['sd']:.4f}"
        )
    wall, cpu = command_line_seconds()
    print(f"command line `bayescal geometry {DATA.name} --posterior ...`, start-up included: {wall:.2f} s wall, {cpu:.2f} s CPU")
    print(f"load average (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
