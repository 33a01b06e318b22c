"""Start-up of the command line: each command's time against a bare interpreter's, in one run.

Every case is a fresh process, run ``REPEATS`` times; the medians of its wall
time and of its CPU time (user + system) are reported beside their ratios to
``python -c pass`` measured in the same run, since the machine is shared and
absolute seconds drift with its load (CPU time drifts least).  The heavy
libraries (pinocchio, scipy.stats, pandas, xarray, matplotlib, emcee) are
imported where they are needed, so ``bayescal --help`` imports none of them;
``import scipy.stats`` is timed as the cost one eager import would add.
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from smoke import sized

ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(5, 1)
"""Runs per case; the median damps the shared machine's noise."""


def children_cpu() -> float:
    """CPU seconds (user and system) of this process's finished children so far."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed_runs(arguments: list[str], cwd: Path = ROOT, repeats: int = REPEATS) -> tuple[list[float], float, str]:
    """Wall seconds of each of ``repeats`` fresh runs of ``arguments`` in ``cwd``, their median CPU seconds and the last stdout."""
    walls, cpus = [], []
    for _ in range(repeats):
        began, cpu = time.perf_counter(), children_cpu()
        done = subprocess.run(arguments, capture_output=True, text=True, cwd=cwd)
        walls.append(time.perf_counter() - began)
        cpus.append(children_cpu() - cpu)
        if done.returncode != 0:
            raise SystemExit(f"{' '.join(arguments)} failed: {done.stderr.strip().splitlines()[-1]}")
    return walls, statistics.median(cpus), done.stdout


def command_times(arguments: list[str], cwd: Path = ROOT) -> tuple[list[float], float]:
    """Wall seconds of each of ``REPEATS`` fresh runs of ``arguments`` in the folder ``cwd`` and their median CPU seconds."""
    walls, cpu, _ = timed_runs(arguments, cwd)
    return walls, cpu


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
            walls, cpu = command_times(arguments)
            wall = statistics.median(walls)
            baseline = baseline or (wall, cpu)
            print(f"{name:46s} wall {wall:6.3f} s ({wall / baseline[0]:5.1f}x)  CPU {cpu:6.3f} s ({cpu / baseline[1]:5.1f}x the bare interpreter)")


if __name__ == "__main__":
    main()
