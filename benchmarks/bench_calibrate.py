"""``bayescal calibrate`` on the demo's Table III twin campaign: the command, the fit in process, against baselines.

The demo's inputs are made first in a temporary folder (``bayescal geometry`` on
Table I, ``bayescal simulate`` of Table III with 3 repeats and seed 1).  Then:

* the command as ``make demo`` runs it (``--geometry``, start-up, test pose and
  JSON included), ``REPEATS`` fresh processes: median, smallest and largest wall
  time and the median CPU time (user + system), beside ``python -c pass`` and
  ``import scipy.special`` run as many times (the eager import the F test's p-value
  no longer needs);
* the fit alone in this process, ``REPEATS`` times alternated with the same fit
  whose exact model solves its equilibria one configuration at a time
  (``bench_campaign_size.loop_offset``, the implementation before
  :mod:`bayescal.robot.batched`): median CPU seconds, their ratio, and the
  diagnostics every fit must keep (R-hat ≤ 1.01, bulk and tail ESS ≥ 1,000 for
  every reported parameter but the noise levels).

CPU time is the steadier figure on the shared machine; one BLAS thread, as the command line sets.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import statistics
from contextlib import nullcontext
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from unittest import mock

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_campaign_size import loop_offset  # noqa: E402
from bench_startup import command_times  # noqa: E402
from smoke import SAMPLER, sized  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(5, 1)


def _fits(campaign_csv: Path, geometry_nc: Path) -> None:
    import numpy as np

    from bayescal.cell.campaign import read_campaign
    from bayescal.cell.config import load_cell
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.priors import posterior_geometry
    from bayescal.inference.samplers import elastostatic_sampler

    warnings.simplefilter("ignore")
    cell = load_cell(ROOT / "data" / "kr270.toml")
    campaign = read_campaign(campaign_csv, cell=cell)
    model = ElastostaticModel.from_cell(cell, posterior_geometry(geometry_nc, cell.compensator), sampler=elastostatic_sampler(**SAMPLER))
    model.fit(campaign, np.random.default_rng(0))  # the first call pays for lazy imports
    seconds: dict[str, list[float]] = {"batched": [], "loop": []}
    results = {}
    for _ in range(REPEATS):
        for name in seconds:
            patch = mock.patch("bayescal.inference.exact.linearisation_offset", loop_offset) if name == "loop" else nullcontext()
            with patch:
                cpu = time.process_time()
                results[name] = model.fit(campaign, np.random.default_rng(0))
                seconds[name].append(time.process_time() - cpu)
    batched, loop = statistics.median(seconds["batched"]), statistics.median(seconds["loop"])
    summary = results["batched"].summary()
    reported = summary.drop([n for n in summary.index if n.startswith("sigma")])
    print(
        f"fit in process (median of {REPEATS}): {batched:.3f} s CPU; with the per-configuration loop {loop:.3f} s CPU "
        f"({loop / batched:.2f}x); R-hat max {reported['r_hat'].max():.4f}, min bulk ESS {reported['ess_bulk'].min():,.0f}, "
        f"min tail ESS {reported['ess_tail'].min():,.0f} ({len(reported)} parameters)"
    )
    moved = np.max(np.abs(summary["mean"] - results["loop"].summary()["mean"]) / summary["sd"])
    print(f"posterior means of the two fits differ by at most {moved:.1e} sd")


def main() -> None:
    python = sys.executable
    with tempfile.TemporaryDirectory() as folder:
        geometry, campaign = Path(folder) / "geometry_posterior.nc", Path(folder) / "campaign.csv"
        for arguments in (
            ["geometry", "data/table1_geometry.csv", "--posterior", str(geometry)],
            ["simulate", "--plan", "data/table3_plan.csv", "--config", "data/kr270.toml", "--repeats", "3", "--seed", "1", "-o", str(campaign)],
        ):
            subprocess.run([python, "-m", "bayescal", *arguments], check=True, capture_output=True, cwd=ROOT)
        cases = {
            "python -c pass": [python, "-c", "pass"],
            "import scipy.special": [python, "-c", "import scipy.special"],
            "bayescal calibrate (make demo's step 3)": [
                python, "-m", "bayescal", "calibrate", str(campaign), "--config", "data/kr270.toml", "--geometry", str(geometry), "--json"],
        }
        for name, arguments in cases.items():
            walls, cpu = command_times(arguments)
            print(
                f"{name:40s} wall median {statistics.median(walls):5.2f} s (runs {min(walls):.2f}-{max(walls):.2f} s)  "
                f"CPU median {cpu:5.2f} s"
            )
        _fits(campaign, geometry)


if __name__ == "__main__":
    main()
