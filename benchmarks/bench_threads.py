"""The fit called from a user's own Python script: BLAS's default threads against one thread.

The command line sets ``OPENBLAS_NUM_THREADS=1`` before NumPy loads; a script that
calls ``ElastostaticModel(...).fit(...)`` does not, and gets OpenBLAS's default
(one thread per core).  This script leaves the environment alone, as such a script
would.  It makes the demo's Table III twin campaign (``bayescal geometry`` on Table I,
``bayescal simulate`` of Table III with 3 repeats and seed 1, in a temporary folder)
and a campaign of ``--configurations`` random configurations (default 10,000) on the
digital twin, and fits each ``REPEATS`` times in this process, alternating:

* ``library``: the fit as a script calls it, BLAS threads as the process has them;
* ``one thread``: the same inside ``threadpoolctl.threadpool_limits(1, user_api="blas")``;
* ``BASELINE``: the same with the library's own limit lifted
  (:func:`bayescal.threads.one_blas_thread` replaced by a no-op in
  :mod:`bayescal.inference.elastostatic`), the library before it limited its threads.

Printed: BLAS's threads as found, the load average, the median CPU and wall seconds of
each, the ratios against ``one thread``, the largest difference of each one's posterior
means from ``one thread``'s in posterior sds (they share the seed), and the per-call cost
of the limit itself against a fresh ``threadpool_limits``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from contextlib import nullcontext
from pathlib import Path
from unittest import mock

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from smoke import SAMPLER, sized

ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(5, 1)


def _campaigns(folder: Path) -> tuple[Path, Path]:
    """Geometry posterior and Table III twin campaign, made by the command line as ``make demo`` makes them."""
    geometry, table3 = folder / "geometry.nc", folder / "table3.csv"
    for arguments in (
        ["geometry", "data/table1_geometry.csv", "--posterior", str(geometry)],
        ["simulate", "--plan", "data/table3_plan.csv", "--config", "data/kr270.toml", "--repeats", "3", "--seed", "1", "-o", str(table3)],
    ):
        subprocess.run([sys.executable, "-m", "bayescal", *arguments], check=True, capture_output=True, cwd=ROOT)
    return geometry, table3


def _random_campaign(cell, n: int):
    """``n`` random configurations within the joint limits, one repeat, simulated on the digital twin."""
    from bayescal_studies.studies.elastostatic_coverage import random_plan
    from bayescal.twin.simulator import DigitalTwin

    rng = np.random.default_rng(n)
    return DigitalTwin(cell).simulate(random_plan(cell, n, 1, rng), 1, rng)


def _fits(model, campaign, label: str) -> None:
    contexts = {
        "library": nullcontext,
        "one thread": lambda: threadpool_limits(1, user_api="blas"),
        "BASELINE": lambda: mock.patch("bayescal.inference.elastostatic.one_blas_thread", nullcontext),
    }
    model.fit(campaign, np.random.default_rng(0))  # the first call pays for lazy imports
    cpu: dict[str, list[float]] = {name: [] for name in contexts}
    wall: dict[str, list[float]] = {name: [] for name in contexts}
    summaries = {}
    for _ in range(REPEATS):
        for name, context in contexts.items():
            with context():
                began, spent = time.perf_counter(), time.process_time()
                summary = model.fit(campaign, np.random.default_rng(0)).summary()
                cpu[name].append(time.process_time() - spent)
                wall[name].append(time.perf_counter() - began)
            summaries[name] = summary
    reference = summaries["one thread"]
    moved = {name: np.max(np.abs(s["mean"] - reference["mean"]) / reference["sd"]) for name, s in summaries.items() if name != "one thread"}
    print(f"{label} (median of {REPEATS}, load average {os.getloadavg()[0]:.1f}):")
    reference_cpu, reference_wall = statistics.median(cpu["one thread"]), statistics.median(wall["one thread"])
    for name in contexts:
        c, w = statistics.median(cpu[name]), statistics.median(wall[name])
        print(
            f"  {name:10s} {c:6.3f} s CPU ({c / reference_cpu:4.2f}x one thread), {w:6.3f} s wall ({w / reference_wall:4.2f}x), "
            f"wall runs {min(wall[name]):.2f}-{max(wall[name]):.2f} s"
        )
    print("  posterior means against one thread's (same seed): " + ", ".join(f"{name} within {d:.1e} sd" for name, d in moved.items()))


def _overhead() -> None:
    from bayescal.threads import one_blas_thread

    calls = 10_000
    began = time.perf_counter()
    for _ in range(calls):
        with one_blas_thread():
            pass
    per_call = (time.perf_counter() - began) / calls
    began = time.perf_counter()
    for _ in range(100):
        with threadpool_limits(1, user_api="blas"):
            pass
    fresh = (time.perf_counter() - began) / 100
    print(f"one_blas_thread: {per_call * 1e6:.1f} μs a call; threadpool_limits, a new controller each call: {fresh * 1e6:.0f} μs")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--configurations", type=int, default=sized(10_000, 20), help="size of the random campaign (default 10,000; 0 leaves it out)")
    args = parser.parse_args()
    from bayescal.cell.campaign import read_campaign
    from bayescal.cell.config import load_cell
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.priors import posterior_geometry
    from bayescal.inference.samplers import elastostatic_sampler

    blas = [(pool["internal_api"], pool["num_threads"]) for pool in threadpool_info() if pool["user_api"] == "blas"]
    print(f"BLAS as the script finds it: {blas}; {os.cpu_count()} cores; OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}")
    warnings.simplefilter("ignore")
    cell = load_cell(ROOT / "data" / "kr270.toml")
    with tempfile.TemporaryDirectory() as folder:
        geometry, table3 = _campaigns(Path(folder))
        model = ElastostaticModel.from_cell(cell, posterior_geometry(geometry, cell.compensator), sampler=elastostatic_sampler(**SAMPLER))
        _fits(model, read_campaign(table3, cell=cell), "Table III twin campaign, --geometry")
    if args.configurations:
        _fits(ElastostaticModel.from_cell(cell, sampler=elastostatic_sampler(**SAMPLER)), _random_campaign(cell, args.configurations), f"{args.configurations:,} random configurations")
    _overhead()


if __name__ == "__main__":
    main()
