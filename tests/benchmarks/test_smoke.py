"""Every benchmark script runs to its end at the smoke size (``benchmarks/smoke.py``): a renamed function
breaks the test, not ``make bench`` weeks later.

The scripts run in this process (``runpy``, as ``python benchmarks/bench_x.py`` would) so that they
share one import of the package; the commands some of them time still start processes of their own.
"""

import runpy
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
SCRIPTS = sorted(BENCHMARKS.glob("bench_*.py"))
NEEDS = {"bench_nuts.py": ("jax", "numpyro")}
"""Modules of the ``bench`` extra a script imports, without which it is skipped."""


def test_every_script_is_found():
    assert len(SCRIPTS) >= 9


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda path: path.stem)
def test_script_runs_at_smoke_size(script, monkeypatch, capsys):
    for module in NEEDS.get(script.name, ()):
        pytest.importorskip(module, reason=f"{script.name} needs the bench extra ({module})")
    monkeypatch.setenv("BAYESCAL_BENCH_SMOKE", "1")
    monkeypatch.setattr(sys, "argv", [str(script)])
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    # A script imported by another (bench_startup by bench_calibrate) reads the smoke size once, when first imported.
    for name in [n for n in sys.modules if n == "smoke" or n.startswith("bench_")]:
        monkeypatch.delitem(sys.modules, name)
    runpy.run_path(str(script), run_name="__main__")
    assert capsys.readouterr().out.strip(), f"{script.name} printed nothing"
