"""``make demo`` step by step against the previous code, in one run: each command's time and the same files.

The demo's commands are read from the Makefile's demo recipes and run as ``python -m bayescal``
in two folders, alternately, ``REPEATS`` times each: a temporary one holding a link to the
repository's ``data/`` (the package is the installed working tree's), and the repository's files at
:data:`PREVIOUS` (``previous.py``'s :func:`~previous.previous_tree`), each writing its own
``build/`` (the repository's own ``build/`` is left alone).  Printed: the median wall and CPU seconds (user + system) of every step and of the
whole demo in each tree and their ratio; the wall seconds of ``make demo`` as each tree's Makefile runs it (its steps
at once where they can be); then which of the outputs that carry no time stamp
(the campaign, the plan, the critique's JSON, the review's files) are byte for byte the same.
CPU time is the steadier figure on a shared machine.  At the smoke size: the first two steps,
once, with the working tree's package alone.
"""

from __future__ import annotations

import filecmp
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_startup import children_cpu
from previous import NoHistory, previous_tree
from smoke import SMOKE, sized

ROOT = Path(__file__).resolve().parents[1]
PREVIOUS = "ca6c3fb"
"""The commit the demo is timed against: the last merged round's.  (Commit 5b37cd4 is the one before the plan
search, the critique's and the review's start-up and the compensation were made faster, docs/speed.md.)"""
REPEATS = sized(3, 1)
"""Runs of the demo in each tree; the medians damp the shared machine's noise."""
COMPARED = ("campaign.csv", "plan.csv", "plan.json", "critique.json", "report")
"""Outputs compared byte for byte (the posterior files carry their creation time)."""


def demo_steps(makefile: Path = ROOT / "Makefile") -> list[tuple[list[str], str | None]]:
    """The commands of ``makefile``'s demo, in the order written: each one's arguments after ``bayescal`` and the file its
    stdout goes to.  The demo's steps are the recipes of the ``demo`` target itself, or of its ``demo-*`` targets where the
    demo runs them through make's own scheduling."""
    recipe, started = [], False
    for line in makefile.read_text().splitlines():
        if line.startswith("demo:") or line.startswith("demo-"):
            started = True
        elif started and line.startswith("\t"):
            recipe.append(line.strip())
        elif started and line and not line.startswith("#"):
            started = False
    commands = " ".join(recipe).replace("\\ ", " ").split("$(BIN)/bayescal ")[1:]
    steps = []
    for command in commands:
        words = shlex.split(command)
        output = words[words.index(">") + 1] if ">" in words else None
        steps.append((words[: words.index(">")] if output else words, output))
    return steps


def run_demo(tree: Path, steps) -> list[tuple[float, float]]:
    """Wall and CPU seconds of each step of the demo run in the folder ``tree`` (into its ``build/``)."""
    (tree / "build").mkdir(exist_ok=True)
    times = []
    # this checkout's package where the folder has none of its own (``python -m`` puts the folder first on the path)
    environment = os.environ | {"OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    for arguments, output in steps:
        began, cpu = time.perf_counter(), children_cpu()
        with open(tree / output, "w") if output else open(os.devnull, "w") as stdout:
            done = subprocess.run([sys.executable, "-m", "bayescal", *arguments], cwd=tree, stdout=stdout, stderr=subprocess.PIPE,
                                  text=True, env=environment)
        if done.returncode != 0:
            raise SystemExit(f"bayescal {' '.join(arguments)} failed in {tree}: {done.stderr.strip().splitlines()[-1]}")
        times.append((time.perf_counter() - began, children_cpu() - cpu))
    return times


def make_demo(tree: Path, makefile: Path) -> float:
    """Wall seconds of ``make demo`` as ``makefile`` runs it, in the folder ``tree``: its steps one after another or
    several at once, as that Makefile says.  ``bayescal`` is ``python -m bayescal`` run in ``tree``, whose own package,
    if it has one, comes first on the path."""
    with tempfile.TemporaryDirectory() as folder:
        command = Path(folder) / "bayescal"
        command.write_text(f'#!/bin/sh\nexec {shlex.quote(sys.executable)} -m bayescal "$@"\n')
        command.chmod(0o755)
        environment = os.environ | {"OPENBLAS_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
        began = time.perf_counter()
        done = subprocess.run(["make", "-s", "-f", str(makefile), "demo", f"BIN={folder}", "STAMP="], cwd=tree,
                              capture_output=True, text=True, env=environment)
        if done.returncode != 0:
            raise SystemExit(f"make demo failed in {tree}: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
        return time.perf_counter() - began


def _same(a: Path, b: Path) -> bool:
    if a.is_dir():
        comparison = filecmp.dircmp(a, b)
        return not (comparison.left_only or comparison.right_only) and all(
            filecmp.cmp(a / name, b / name, shallow=False) for name in comparison.common_files
        )
    return filecmp.cmp(a, b, shallow=False)


def _medians(runs: list[list[tuple[float, float]]]) -> list[tuple[float, float]]:
    return [(statistics.median(r[k][0] for r in runs), statistics.median(r[k][1] for r in runs)) for k in range(len(runs[0]))]


def makefile(tree: Path) -> Path:
    """The Makefile of ``tree``: its own where it has one (an earlier revision's), the working tree's otherwise."""
    return tree / "Makefile" if (tree / "Makefile").exists() else ROOT / "Makefile"


def compare(steps, trees: dict[str, Path]) -> None:
    """Time the demo in the two ``trees`` (the current one first), alternately, and compare their outputs."""
    runs = {name: [] for name in trees}
    for _ in range(REPEATS):
        for name, tree in trees.items():
            runs[name].append(run_demo(tree, steps))
    (now, now_tree), (before, before_tree) = trees.items()
    new, old = _medians(runs[now]), _medians(runs[before])
    print(f"make demo, medians of {REPEATS} (wall, CPU seconds), {now} against {before}:")
    for (arguments, _), (wall, cpu), (old_wall, old_cpu) in zip(steps, new, old):
        print(f"  {arguments[0]:10s} {wall:6.2f} s wall {cpu:6.2f} s CPU   before {old_wall:6.2f} s wall {old_cpu:6.2f} s CPU   "
              f"{old_cpu / cpu:4.2f}x the CPU")
    total = [sum(t[k] for t in new) for k in (0, 1)]
    old_total = [sum(t[k] for t in old) for k in (0, 1)]
    print(f"  {'all':10s} {total[0]:6.2f} s wall {total[1]:6.2f} s CPU   before {old_total[0]:6.2f} s wall {old_total[1]:6.2f} s CPU   "
          f"{old_total[1] / total[1]:4.2f}x the CPU")
    whole = {name: statistics.median(make_demo(tree, makefile(tree)) for _ in range(REPEATS)) for name, tree in trees.items()}
    print(f"  make demo as its Makefile runs it (the steps at once where they can be): {whole[now]:6.2f} s wall   "
          f"before {whole[before]:6.2f} s wall   {whole[before] / whole[now]:4.2f}x")
    for name in COMPARED:
        same = _same(now_tree / "build" / name, before_tree / "build" / name)
        print(f"  build/{name}: {'the same, byte for byte' if same else 'DIFFERENT'}")


def main() -> None:
    print(f"load average (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    steps = demo_steps()
    with tempfile.TemporaryDirectory() as folder:
        now = Path(folder)
        (now / "data").symlink_to(ROOT / "data")
        if SMOKE:
            for (arguments, _), (wall, cpu) in zip(steps, run_demo(now, steps[:2])):
                print(f"  {arguments[0]:10s} {wall:6.2f} s wall {cpu:6.2f} s CPU")
            return
        try:
            with previous_tree(PREVIOUS) as before:
                compare(steps, {"now": now, PREVIOUS: before})
        except NoHistory as reason:
            print(f"no baseline: {reason}")


if __name__ == "__main__":
    main()
