"""The classical model's lack-of-fit test on independent-generator campaigns, this checkout against :data:`PREVIOUS`.

The research studies trace the repeats' lack of fit over many campaigns with the critique's catalogue empty
(``bayescal_studies.studies.independent_detection.independent_lack_of_fit``).  Until :data:`PREVIOUS` such a critique
still fitted the tracker's drift to the campaign's repeat groups, although ``drift`` was no candidate.  Each tree runs
the study on the same campaigns (``gear_play`` at its default, :data:`SEEDS`) in a fresh process, ``REPEATS``
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
"""Consecutive: the study seeds its campaigns from the first."""
ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(3, 1)
"""Runs per tree; the median damps the shared machine's noise."""

TASK = f"""
import json, warnings
from concurrent.futures import ThreadPoolExecutor
from bayescal_studies.studies.independent_detection import independent_lack_of_fit
warnings.simplefilter("ignore")
with ThreadPoolExecutor(1) as executor:
    table = independent_lack_of_fit("data/kr270.toml", ("gear_play",), (1.0,), n_seeds={len(SEEDS)}, n_null=0,
                                    first_seed={SEEDS[0]}, executor=executor)
print(json.dumps(table["statistic"].tolist()))
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
