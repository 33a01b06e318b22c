"""``bayescal simulate`` of a large plan against the previous code, in one run: CPU seconds, peak memory, the same file.

The plan is Table III's fifteen configurations and loads repeated to :data:`CONFIGURATIONS` rows
(written to a temporary file).  ``python -m bayescal simulate --repeats 3 --seed 1`` runs on it in
the working tree and in the repository's files at :data:`PREVIOUS` (``previous.py``'s
:func:`~previous.previous_tree`), alternately, :data:`REPEATS` times each, one BLAS thread.
Printed: each tree's median wall and CPU seconds (user + system) and its largest peak resident
memory (of the command's own process, start-up included), their ratios, and whether the two
campaigns are byte for byte the same.  CPU time is the steadier figure on a shared machine.
"""

from __future__ import annotations

import filecmp
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from previous import NoHistory, previous_tree
from smoke import SMOKE, sized

ROOT = Path(__file__).resolve().parents[1]
PREVIOUS = "ca6c3fb"
"""The commit simulate is timed against: the last before the campaign writer, the table reader and the chain's
poses were made faster this round."""
CONFIGURATIONS = sized(100_000, 30)
"""Configurations of the simulated plan (900,000 rows of campaign at 3 repeats and 3 markers)."""
REPEATS = sized(3, 1)
"""Runs in each tree; the medians damp the shared machine's noise."""


def write_plan(path: Path) -> None:
    """Table III's rows, its header and no comment, repeated to :data:`CONFIGURATIONS` rows."""
    lines = [line for line in (ROOT / "data" / "table3_plan.csv").read_text().splitlines() if line and not line.startswith("#")]
    rows = lines[1:]
    path.write_text("\n".join([lines[0]] + [rows[k % len(rows)] for k in range(CONFIGURATIONS)]) + "\n")


def run(tree: Path, plan: Path, output: Path) -> tuple[float, float, float]:
    """Wall seconds, CPU seconds and peak resident memory (MB) of one simulate run with ``tree``'s package."""
    environment = os.environ | {"OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(tree)}
    arguments = [sys.executable, "-m", "bayescal", "simulate", "--plan", str(plan), "--config", str(ROOT / "data" / "kr270.toml"),
                 "--repeats", "3", "--seed", "1", "-o", str(output)]
    began = time.perf_counter()
    process = subprocess.Popen(arguments, cwd=tree, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    # wait4 gives this child's own usage: RUSAGE_CHILDREN's peak memory would be the largest of all children so far
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - began
    error = process.stderr.read().decode()
    process.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"simulate failed in {tree}: {error.strip().splitlines()[-1]}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024


def _line(name: str, runs: list[tuple[float, float, float]]) -> tuple[float, float]:
    wall, cpu = statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)
    memory = max(r[2] for r in runs)
    print(f"  {name:8s} {wall:6.2f} s wall {cpu:6.2f} s CPU  peak {memory:6.0f} MB  (medians of {len(runs)}; largest peak)")
    return cpu, memory


def main() -> None:
    print(f"load average (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    with tempfile.TemporaryDirectory() as folder:
        plan = Path(folder) / "plan.csv"
        write_plan(plan)
        print(f"bayescal simulate of {CONFIGURATIONS:,} configurations, 3 repeats:")
        if SMOKE:
            _line("now", [run(ROOT, plan, Path(folder) / "now.csv")])
            return
        try:
            with previous_tree(PREVIOUS) as before:
                runs: dict[str, list] = {"now": [], PREVIOUS: []}
                for _ in range(REPEATS):
                    runs["now"].append(run(ROOT, plan, Path(folder) / "now.csv"))
                    runs[PREVIOUS].append(run(before, plan, Path(folder) / "before.csv"))
        except NoHistory as reason:
            print(f"no baseline: {reason}")
            return
        (cpu, memory), (old_cpu, old_memory) = _line("now", runs["now"]), _line(PREVIOUS, runs[PREVIOUS])
        print(f"  {old_cpu / cpu:.2f}x the CPU, {old_memory / memory:.2f}x the memory; campaigns "
              f"{'the same, byte for byte' if filecmp.cmp(Path(folder) / 'now.csv', Path(folder) / 'before.csv', shallow=False) else 'DIFFERENT'}")


if __name__ == "__main__":
    main()
