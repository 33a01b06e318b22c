"""The classical model's lack-of-fit test on independent-generator campaigns, this checkout against :data:`PREVIOUS`.

The research studies trace the repeats' lack of fit over many campaigns with the critique's catalogue empty
(``bayescal_studies.studies.independent_detection.independent_lack_of_fit``).  Until :data:`PREVIOUS` such a critique
still fitted the tracker's drift to the campaign's repeat groups, although ``drift`` was no candidate.  Each tree runs
the study's task on the same campaigns (``gear_play`` at its default, :data:`SEEDS`) in a fresh process, ``REPEATS``
times; printed: the median wall and CPU seconds of each, their ratio, and the statistics, which must be the same.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

from bench_startup import timed_runs
from previous import NoHistory, previous_tree
from smoke import sized

PREVIOUS = "5018951"
"""The last commit whose critique fitted the drift with ``drift`` out of its catalogue."""
SEEDS = sized((9001, 9002, 9003), (9001,))
ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(3, 1)
"""Runs per tree; the median damps the shared machine's noise."""

TASK = f"""
import json, warnings
import numpy as np
from bayescal.cell.config import load_cell
from bayescal_studies.studies.independent_detection import _lack_of_fit_one
warnings.simplefilter("ignore")
cell = load_cell("data/kr270.toml")
print(json.dumps([_lack_of_fit_one(("gear_play", 1.0, s), np.random.default_rng(s), cell)["statistic"] for s in {list(SEEDS)}]))
"""


def main() -> None:
    arguments = [sys.executable, "-c", TASK]
    runs = {"this checkout": timed_runs(arguments, ROOT, REPEATS)}
    try:
        with previous_tree(PREVIOUS) as tree:
            runs[PREVIOUS] = timed_runs(arguments, tree, REPEATS)
    except NoHistory as error:
        print(f"no baseline: {error}")
    print(f"lack of fit of the classical model, {len(SEEDS)} independent gear_play campaigns, one process, median of {REPEATS}:")
    for name, (walls, cpu, _) in runs.items():
        print(f"  {name:14s} wall {statistics.median(walls):6.2f} s  CPU {cpu:6.2f} s")
    if PREVIOUS in runs:
        (walls, cpu, now), (walls0, cpu0, before) = runs["this checkout"], runs[PREVIOUS]
        print(f"  ratio (this / {PREVIOUS}): wall {statistics.median(walls) / statistics.median(walls0):.2f}, CPU {cpu / cpu0:.2f}")
        same = json.loads(now) == json.loads(before)
        print(f"  the same statistics: {same}")
        if not same:
            raise SystemExit(f"the statistics differ: {now.strip()} against {before.strip()}")


if __name__ == "__main__":
    main()
