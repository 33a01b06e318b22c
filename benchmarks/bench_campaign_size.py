"""Time and peak memory of a calibration against the campaign's size.

Campaigns of 100, 1,000 and 10,000 random configurations within the joint
limits (q2 free, one repeat, the cell's tracker) are simulated on the digital
twin and identified with the default exact model, each in a fresh process so
that its peak resident memory is its own.  Cost should grow no faster than
linearly with the number of configurations.  Sizes can be given as arguments:
``python benchmarks/bench_campaign_size.py 100 1000``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

RUN = """
import resource, sys, time, warnings
import numpy as np
warnings.simplefilter("ignore")
from bayescal.cell.config import load_cell
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.studies.elastostatic_coverage import random_plan
from bayescal.twin.simulator import DigitalTwin
n = int(sys.argv[1])
cell = load_cell(sys.argv[2])
rng = np.random.default_rng(n)
plan = random_plan(cell, n, 1, rng)
campaign = DigitalTwin(cell).simulate(plan, 1, rng)
began, cpu = time.perf_counter(), time.process_time()
results = ElastostaticModel.from_cell(cell).fit(campaign, 0)
wall, cpu = time.perf_counter() - began, time.process_time() - cpu
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(f"{n:6d} configurations {campaign.n_equations:7d} equations  fit {wall:7.1f} s wall {cpu:7.1f} s CPU  "
      f"peak memory {peak:6.0f} MB  R-hat max {results.diagnostics()['r_hat_max']:.3f}")
"""


def main(sizes: list[int]) -> None:
    for n in sizes:
        done = subprocess.run([sys.executable, "-c", RUN, str(n), str(ROOT / "data" / "kr270.toml")], capture_output=True, text=True)
        print(done.stdout.strip() or f"{n:6d} configurations failed: {done.stderr.strip().splitlines()[-1]}")


if __name__ == "__main__":
    main([int(arg) for arg in sys.argv[1:]] or [100, 1000, 10000])
