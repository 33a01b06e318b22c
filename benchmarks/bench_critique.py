"""``bayescal critique`` on the demo's campaign against the previous code, in one run: the same JSON, in a fraction of the time.

The demo's campaign (``make demo``: the twin's Table III plan, 3 repeats, seed 1) is
criticised in this process by the package and by the previous code path
(``bayescal/critique/compare.py`` of commit :data:`PREVIOUS`, loaded from the repository's history
by ``previous.py``: every fold refitted by its own loop of weighted least squares), one after the other, ``REPEATS`` times each.  Printed: the median CPU and
wall seconds of each and their ratio; whether the two JSON payloads agree (every key,
string and count equal, and the largest relative difference of their numbers); the smallest
fraction of a column left unexplained by those before it in any batched fold (what
``compare.COLLINEAR_MARGIN`` guards); and the median wall and CPU seconds of the whole
command, start-up included, beside a bare interpreter's and beside the command at
:data:`PREVIOUS_COMMAND` (the repository's files at that commit, ``previous.py``'s
``previous_tree``), whose JSON must be the same byte for byte.  The script stops when the payloads
differ by more than ``AGREEMENT`` or in anything but their numbers.  One BLAS thread, as the
command line sets.
"""

from __future__ import annotations

import json
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_startup import command_times
from previous import NoHistory, previous, previous_tree
from smoke import sized

import bayescal.critique.compare as compare
import bayescal.critique.model as critique_model
from bayescal.cell.campaign import read_campaign, write_campaign
from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.twin.simulator import DigitalTwin

PREVIOUS = "f6f3e09"
"""The commit whose ``bayescal/critique/compare.py`` is the baseline: the last before the folds were batched."""

PREVIOUS_COMMAND = "5b37cd4"
"""The commit whose command line is the baseline of the command's time: the last before SciPy's ``stats`` was
left out of the geometry critique's import and xarray out of the results' (start-up only: the same JSON)."""

ROOT = Path(__file__).resolve().parents[1]
REPEATS = sized(5, 1)
"""Critiques per code path; the median damps the shared machine's noise."""
AGREEMENT = 1e-9
"""Largest relative difference allowed between the two payloads' numbers: the batched folds sum the
normal equations in another order, which moves the last digits only (measured: docs/critique.md)."""


def _gaussian_from(baseline):
    """``cross_validate`` with the Gaussian models' folds the baseline's, the Student-t models' today's.

    The Student-t folds were never batched: each is fitted alone in both, and since the baseline its weight is shared
    by a row's three coordinates, which the baseline's code does not know (docs/critique.md)."""

    def cross_validate(y, X, scale, group, config, *, robust=False, unit=None):
        if robust:
            return compare.cross_validate(y, X, scale, group, config, robust=True, unit=unit)
        return baseline(y, X, scale, group, config)

    return cross_validate


def _times(run) -> tuple[float, float, object]:
    """Median CPU and wall seconds of ``REPEATS`` calls of ``run``, and its last result."""
    cpus, walls = [], []
    for _ in range(REPEATS):
        cpu, wall = time.process_time(), time.perf_counter()
        result = run()
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    return statistics.median(cpus), statistics.median(walls), result


def _largest_difference(a, b, path="") -> float:
    """Largest relative difference of the numbers of two JSON payloads; raises when anything else differs."""
    if isinstance(a, dict):
        if a.keys() != b.keys():
            raise SystemExit(f"the payloads' keys differ at {path or 'the top'}")
        return max((_largest_difference(a[k], b[k], f"{path}.{k}") for k in a), default=0.0)
    if isinstance(a, list):
        if len(a) != len(b):
            raise SystemExit(f"the payloads' lists differ in length at {path}")
        return max((_largest_difference(u, v, f"{path}[{i}]") for i, (u, v) in enumerate(zip(a, b))), default=0.0)
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) / max(abs(a), abs(b)) if a != b else 0.0
    if a != b:
        raise SystemExit(f"the payloads differ at {path}: {a!r} against {b!r}")
    return 0.0


def main() -> None:
    cell = load_cell(ROOT / "data" / "kr270.toml")
    plan = read_plan(ROOT / "data" / "table3_plan.csv", cell.robot, max_load_kg=cell.max_force / cell.gravity, loading=cell.loading)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "campaign.csv"
        write_campaign(DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1)), path)
        campaign = read_campaign(path, cell=cell)

        fractions = []
        measured = compare.smallest_unexplained_fraction
        compare.smallest_unexplained_fraction = lambda *a: fractions.append(measured(*a)) or fractions[-1]
        new_cpu, new_wall, new = _times(lambda: critique_model.Critique(cell).run(campaign))
        compare.smallest_unexplained_fraction = measured

        try:
            critique_model.cross_validate = _gaussian_from(previous("critique", ("compare",), PREVIOUS).compare.cross_validate)
        except NoHistory as reason:
            print(f"no baseline: {reason}")
            return
        try:
            old_cpu, old_wall, old = _times(lambda: critique_model.Critique(cell).run(campaign))
        finally:
            critique_model.cross_validate = compare.cross_validate

        difference = _largest_difference(old.to_json(), new.to_json())
        print(f"critique, demo campaign ({new.n_configs} configurations, {new.n_equations} equations), median of {REPEATS}:")
        print(f"  previous code   CPU {old_cpu:6.3f} s  wall {old_wall:6.3f} s")
        print(f"  batched folds   CPU {new_cpu:6.3f} s  wall {new_wall:6.3f} s  ({old_cpu / new_cpu:4.1f}x less CPU)")
        print(f"  same JSON: every key, string and count; numbers to a relative {difference:.1e}")
        print(f"  smallest unexplained fraction of a column in a batched fold: {min(np.min(f) for f in fractions):.3g}"
              f" (folds refitted alone below {compare.COLLINEAR_MARGIN * compare.COLLINEAR_TOLERANCE:g})")
        if difference > AGREEMENT:
            raise SystemExit(f"the payloads' numbers differ by a relative {difference:.1e}, above {AGREEMENT:g}")

        python = sys.executable
        command = [python, "-m", "bayescal", "critique", str(path), "--config", "data/kr270.toml", "--json"]
        cases = {"python -c pass": [python, "-c", "pass"], "bayescal critique CAMPAIGN --config data/kr270.toml --json": command}
        for name, arguments in cases.items():
            walls, cpu = command_times(arguments)
            print(f"  {name:58s} wall {statistics.median(walls):6.3f} s  CPU {cpu:6.3f} s")
        _previous_command(command, cpu)


def _previous_command(command: list[str], cpu: float) -> None:
    """The command's time at :data:`PREVIOUS_COMMAND` beside today's ``cpu``, and whether the two print the same JSON."""
    try:
        with previous_tree(PREVIOUS_COMMAND) as before:
            walls, old_cpu = command_times(command, cwd=before)
            old, new = (subprocess.run(command, capture_output=True, cwd=folder).stdout for folder in (before, ROOT))
    except NoHistory as reason:
        print(f"  no baseline of the command: {reason}")
        return
    differing = _differing(json.loads(old), json.loads(new))
    verdict = "byte for byte the same" if old == new else f"differs in {len(differing)} values, the first {differing[0] if differing else 'none'}"
    print(f"  {'the same command at ' + PREVIOUS_COMMAND:58s} wall {statistics.median(walls):6.3f} s  CPU {old_cpu:6.3f} s "
          f"({old_cpu / cpu:4.2f}x today's CPU); the JSON {verdict}")


def _differing(a, b, path="") -> list[str]:
    """Where two JSON payloads differ (other work since :data:`PREVIOUS_COMMAND` may change the critique's numbers)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [p for k in a.keys() | b.keys() for p in (_differing(a.get(k), b.get(k), f"{path}.{k}"))]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [p for i, (u, v) in enumerate(zip(a, b)) for p in _differing(u, v, f"{path}[{i}]")]
    return [] if a == b else [path]


if __name__ == "__main__":
    main()
