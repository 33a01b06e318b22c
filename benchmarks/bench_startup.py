"""Start-up of the command line: each command's wall time against a bare interpreter's, in one run.

Every case is a fresh process, run ``REPEATS`` times; the median is reported
beside its ratio to ``python -c pass`` measured in the same run, since the
machine is shared and absolute seconds drift with its load.  The heavy
libraries (pinocchio, scipy.stats, pandas, xarray, matplotlib, emcee) are
imported where they are needed, so ``bayescal --help`` imports none of them;
``import scipy.stats`` is timed as the cost one eager import would add.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 5
"""Runs per case; the median damps the shared machine's noise."""


def _wall(arguments: list[str]) -> float:
    times = []
    for _ in range(REPEATS):
        began = time.perf_counter()
        done = subprocess.run(arguments, capture_output=True, text=True, cwd=ROOT)
        times.append(time.perf_counter() - began)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(arguments)} failed: {done.stderr.strip().splitlines()[-1]}")
    return statistics.median(times)


def main() -> None:
    python = sys.executable
    with tempfile.TemporaryDirectory() as folder:
        campaign = str(Path(folder) / "campaign.csv")
        subprocess.run(
            [python, "-m", "bayescal", "simulate", "--plan", "data/table3_plan.csv", "--config", "data/kr270.toml",
             "--repeats", "3", "--seed", "1", "-o", campaign],
            check=True, capture_output=True, cwd=ROOT,
        )
        cases = {
            "python -c pass (baseline)": [python, "-c", "pass"],
            "import scipy.stats (one eager import)": [python, "-c", "import scipy.stats"],
            "bayescal --help": [python, "-m", "bayescal", "--help"],
            "bayescal simulate --help": [python, "-m", "bayescal", "simulate", "--help"],
            "import bayescal.inference.elastostatic": [python, "-c", "import bayescal.inference.elastostatic"],
            "bayescal calibrate, Table III twin campaign": [
                python, "-m", "bayescal", "calibrate", campaign, "--config", "data/kr270.toml", "--json"],
        }
        baseline = None
        for name, arguments in cases.items():
            wall = _wall(arguments)
            baseline = baseline or wall
            print(f"{name:48s} {wall:6.3f} s  {wall / baseline:6.1f}x the bare interpreter")


if __name__ == "__main__":
    main()
