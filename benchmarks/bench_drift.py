"""``bayescal critique`` on campaigns whose repeats show a drift, against the command before the drift's column took a
steady rate: the causes each names, and the time each takes.

The campaigns are the independent generator's ``thermal_drift`` at its default (0.2 mm/h, repeats back to back,
reading times), seeds :data:`SEEDS`, as ``bayescal_studies.studies.critique_rates`` writes them.  The command runs
``REPEATS`` times on each in this checkout and in the repository's files at :data:`PREVIOUS` (``previous.py``'s
``previous_tree``).  Printed per campaign: each tree's causes, its median wall and CPU seconds, and their ratios.  At
:data:`PREVIOUS` the random walk alone gave the drift's column, and where `drift` was named the drift was fitted again
for the rows extended by the test pose (``docs/critique.md``, *The drift's column from a steady rate*).
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
from pathlib import Path

from bench_startup import timed_runs
from previous import NoHistory, previous_tree
from smoke import sized

from bayescal.cell.config import load_cell
from bayescal_studies.studies.critique_rates import GENERATORS

PREVIOUS = "413eff9"
"""The last commit whose drift column was the random walk's alone."""
SEEDS = sized((9001, 9003), (9003,))
"""9001: the walk alone left the drift `unexplained`, the rate names it; 9003: both name it."""
ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(3, 1)
"""Runs of the command per tree; the median damps the shared machine's noise."""


def _critique(campaign: Path, cwd: Path) -> tuple[list[str], float, float]:
    """The causes of ``bayescal critique`` run in ``cwd`` on ``campaign``, and its median wall and CPU seconds."""
    arguments = [sys.executable, "-m", "bayescal", "critique", str(campaign), "--config", "data/kr270.toml", "--json"]
    walls, cpu, stdout = timed_runs(arguments, cwd, REPEATS)
    return json.loads(stdout)["causes"], statistics.median(walls), cpu


def main() -> None:
    cell = load_cell(ROOT / "data" / "kr270.toml")
    with tempfile.TemporaryDirectory() as folder:
        campaigns = {}
        for seed in SEEDS:
            (Path(folder) / str(seed)).mkdir()
            campaigns[seed] = GENERATORS["independent"].write("thermal_drift", 1.0, seed, False, Path(folder) / str(seed),
                                                              cell, ROOT / "data" / "table3_plan.csv")[0]
        trees = {"this checkout": {seed: _critique(path, ROOT) for seed, path in campaigns.items()}}
        try:
            with previous_tree(PREVIOUS) as tree:
                trees[PREVIOUS] = {seed: _critique(path, tree) for seed, path in campaigns.items()}
        except NoHistory as error:
            print(f"no baseline: {error}")
    for seed in SEEDS:
        print(f"thermal_drift, seed {seed}:")
        for name, results in trees.items():
            causes, wall, cpu = results[seed]
            print(f"  {name:14s} causes {', '.join(causes) or '(adequate)':24s} wall {wall:6.2f} s  CPU {cpu:6.2f} s")
        if PREVIOUS in trees:
            (_, wall, cpu), (_, wall0, cpu0) = trees["this checkout"][seed], trees[PREVIOUS][seed]
            print(f"  ratio (this / {PREVIOUS}): wall {wall / wall0:.2f}, CPU {cpu / cpu0:.2f}")


if __name__ == "__main__":
    main()
