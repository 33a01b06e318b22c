"""``bayescal plan``'s searches against the previous code, in one run: the same plans, in a fraction of the time.

For each case the designer of the package and the previous one
(:data:`PREVIOUS`: the plan designer and the batched chain of the last merged round,
loaded from the repository's history by ``previous.py``)
design a plan from the same seed in this process, one after the other:

* ``exact``: the default exact model, 5 × 3, 3 starts, the test-pose criterion (``bayescal plan --config data/kr270.toml``);
* ``linear``: the same with eq 31's linear model (``--model linear``);
* each of these again with its starts in processes forked on this process's cores, as the command runs them: the
  wall time, and whether the plan and the starts' values are those of one process;
* ``discriminate``: the plan that separates ``backlash`` from ``nonlinear_stiffness`` on a tied
  campaign (the twin's Table III campaign, 3 repeats, seed 0, ``backlash=0.002``), 50-280 kg,
  5 × 12, 4 starts (``--criterion discriminate``, docs/critique.md).

Printed for each: CPU and wall seconds of each designer and their ratio, whether the two plans are
the same (largest joint-angle difference), and the largest relative difference of the criterion
values each start reached; the script stops when the plans differ or those values differ by more
than :data:`CRITERION_AGREEMENT`.  CPU time is the steadier figure on a shared machine; one BLAS thread, as
the command line sets.  Command-line start-up (about a second) is not included.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
import time
import warnings
from pathlib import Path

import numpy as np

# this checkout's package, not the one installed (a second working tree of the repository shares one virtualenv)
sys.path[:0] = [str(Path(__file__).resolve().parent), str(Path(__file__).resolve().parents[1])]

from previous import NoHistory, previous  # noqa: E402
from smoke import SMOKE  # noqa: E402

PREVIOUS = "6f68a1f"
"""The commit whose ``bayescal/design`` and ``bayescal/robot/batched.py`` are the baseline: the one before the discriminating
search ranked only the options its bound cannot rule out (docs/speed.md).  (Commit ca6c3fb is the round before that;
5b37cd4 the one before the feasibility checks, the criteria's masks, the exchange's pools and the chain's cross products
lost their overheads, docs/speed.md; f4e0a75 the searches before batching, docs/design.md.)"""
MODULES = (
    "criteria", "linearisation", "loads", "constraints", "exchange", "refinement", "optimise", "separation", "discriminating_search", "discriminate"
)
"""The design modules at :data:`PREVIOUS`, in an order in which each imports only those before it."""


def _previous_design():
    """``bayescal/design`` at :data:`PREVIOUS` on the batched chain at :data:`PREVIOUS`."""
    previous("robot", ("batched",), PREVIOUS)
    return previous("design", MODULES, PREVIOUS, redirect={"bayescal.robot.batched": "previous_robot.batched"})

ROOT = Path(__file__).resolve().parents[1]
SEED = 0
FIXED = ("ca6c3fb", "5b37cd4", "f4e0a75")
"""Baselines whose discriminating designs scored option ``o`` at candidate ``o // 12`` instead of ``o // 4``: the
discriminating plans differ from theirs, and only the times compare."""
CRITERION_AGREEMENT = 1e-12
"""Largest relative difference allowed between the criterion values each start reached under the two designers.  Against
5b37cd4 the criteria were scored from eigenvalues where they are now from a Cholesky factor, which moves their last digits
(measured on the linear model: 0 for the test-pose criterion, 2.2e-16 for d-optimal, 1.1e-14 for the compensator's), and
the discriminating search ranked its candidates by separations summed in another order (6.1e-15); against ca6c3fb, 0."""
OPTIONS = {"exact": {}, "linear": {}} if not SMOKE else {"linear": {"starts": 1, "refine_steps": 5, "candidates_per_angle": 3}}
"""Options of the plan searches: the command's defaults, or one linear start on a few candidates at the smoke size."""
DISCRIMINATE = {} if not SMOKE else {"per_angle": 2, "starts": 1, "candidates_per_angle": 2}


def _timed(function):
    began, cpu = time.perf_counter(), time.process_time()
    result = function()
    return result, time.perf_counter() - began, time.process_time() - cpu


def _line(name: str, new: tuple, old: tuple, plans: tuple[np.ndarray, np.ndarray], starts: tuple, *, same: bool = True) -> None:
    """Print one case's times and agreement; stop when plans or criterion values that should agree (``same``) do not."""
    same_plan = plans[0].shape == plans[1].shape and np.array_equal(plans[0], plans[1])
    moved = np.max(np.abs(plans[0] - plans[1])) if plans[0].shape == plans[1].shape else np.inf
    values = np.abs(np.array(starts[0]) / np.array(starts[1]) - 1.0).max()
    print(
        f"{name:<13} new {new[2]:6.2f} s CPU ({new[1]:6.2f} s wall)  previous {old[2]:6.2f} s CPU ({old[1]:6.2f} s wall)  "
        f"ratio {old[2] / new[2]:5.1f}x CPU  same plan: {'yes' if same_plan else 'NO'} (largest angle difference {np.degrees(moved):.1e} deg), "
        f"criterion of each start within {values:.1e} (relative)",
        flush=True,
    )
    if not same_plan and same:
        sys.exit(f"{name}: the package's plan differs from the previous code's for the same seed")
    if values > CRITERION_AGREEMENT and same:
        sys.exit(f"{name}: the starts' criterion values differ from the previous code's by a relative {values:.1e}, above {CRITERION_AGREEMENT:g}")


def plans(cell) -> None:
    Previous = _previous_design().optimise.PlanDesigner

    from bayescal.design.optimise import PlanDesigner

    from bayescal.forked import available_cores

    for model, options in OPTIONS.items():
        new = _timed(lambda: PlanDesigner(cell, model=model).optimise(5, 3, "test-pose", rng=SEED, **options))
        old = _timed(lambda: Previous(cell, model=model).optimise(5, 3, "test-pose", rng=SEED, **options))
        _line(model, new, old, (new[0].plan.q, old[0].plan.q), (new[0].starts, old[0].starts))
        # the starts as `bayescal plan` runs them, in processes forked on this process's cores (their CPU is not this process's)
        forked = _timed(lambda: PlanDesigner(cell, model=model).optimise(5, 3, "test-pose", rng=SEED, workers=available_cores(), **options))
        same = np.array_equal(forked[0].plan.q, new[0].plan.q) and forked[0].starts == new[0].starts
        print(f"{model + ', forked':<13} {forked[1]:6.2f} s wall on {available_cores()} cores against {new[1]:6.2f} s in one process  "
              f"same plan and starts: {'yes' if same else 'NO'}", flush=True)
        if not same:
            sys.exit(f"{model}: the starts run in forked processes gave another plan than one process")


def discriminate(cell) -> None:
    baseline = _previous_design()
    previous_space, Previous = baseline.constraints.load_design_space, baseline.discriminate.DiscriminatingDesigner

    from bayescal.cell.plan import read_plan
    from bayescal.design.constraints import load_design_space
    from bayescal.design.discriminate import DiscriminatingDesigner
    from bayescal.twin.effects import parse_effect
    from bayescal.twin.simulator import DigitalTwin

    plan = read_plan(ROOT / "data" / "table3_plan.csv", cell.robot)
    tie = DigitalTwin(cell, [parse_effect("backlash=0.002")]).simulate(plan, 3, np.random.default_rng(0))
    between = ("backlash", "nonlinear_stiffness")
    new = _timed(lambda: DiscriminatingDesigner(cell, between, tie, load_design_space(cell, mass_range=(50, 280))).optimise(rng=SEED, **DISCRIMINATE))
    old = _timed(lambda: Previous(cell, between, tie, previous_space(cell, mass_range=(50, 280))).optimise(rng=SEED, **DISCRIMINATE))
    # ca6c3fb scored each option at another candidate's joints (docs/critique.md): its plans are not this one's
    _line("discriminate", new, old, (new[0].plan.q, old[0].plan.q), (new[0].starts, old[0].starts), same=PREVIOUS not in FIXED)


def main() -> None:
    from bayescal.cell.config import load_cell

    warnings.simplefilter("ignore")
    print(f"load average (1, 5, 15 min): {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    cell = load_cell(ROOT / "data" / "kr270.toml")
    try:
        plans(cell)
        discriminate(cell)
    except NoHistory as reason:
        print(f"no baseline: {reason}")


if __name__ == "__main__":
    main()
