"""Time and peak memory of a calibration against the campaign's size, against the per-configuration loop it replaced.

The first line is the CPU time of one loaded equilibrium of the KR-270, solved for
20,000 configurations together and one configuration at a time.  Then campaigns of 1,000, 10,000 and 100,000 random configurations within the joint
limits (q2 free, one repeat, the cell's tracker) are simulated on the digital
twin and identified with the default exact model, each in a fresh process so
that its peak resident memory is its own (the simulation's included).  In the
same process, up to ``--baseline-max`` configurations (default 10,000), the fit
runs again with the exact model's equilibria solved one configuration at a time
by Pinocchio calls (:func:`loop_offset`, the implementation before
:mod:`bayescal.robot.batched`), and the line gives the ratio of the two fits'
CPU times and the largest difference of their posterior means in posterior
sds.  Cost should grow no faster than linearly with the number of configurations.
Sizes can be given as arguments: ``python benchmarks/bench_campaign_size.py 100 1000``.

Before them, in a process of its own, the twin's simulation of ``--simulate`` random configurations
(default 100,000; one repeat) is timed with its peak memory, against the per-configuration loop it
replaced (:func:`loop_simulate`, timed on the first 2,000 and scaled), and the two's readings
from the same seed are compared.

One BLAS thread, as the command line sets (:func:`bayescal.cli.main`): with
OpenBLAS's default threads on the shared two-core machine the same 10,000-configuration
fit took 12.7 s of CPU instead of 1.7 s.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from smoke import SAMPLER, sized

ROOT = Path(__file__).resolve().parents[1]


def loop_offset(robot, campaign, equations, compliances, k2, compensator, load_point):
    """BASELINE: :func:`bayescal.inference.exact.linearisation_offset` as it was, one configuration after another."""
    import numpy as np

    from bayescal.inference.exact import exact_deflections

    exact = np.empty((len(campaign), 3))
    row_angle = equations.angle[::3]
    for config in np.unique(campaign.config):
        rows = np.flatnonzero(campaign.config == config)
        q = campaign.q[rows[0]]
        k = np.array(compliances, dtype=float)
        if equations.joint is not None:
            k[equations.joint] = compensator.own_compliance(q[equations.joint], k2[row_angle[rows[0]]])
        exact[rows] = exact_deflections(
            robot,
            q,
            campaign.wrench[rows[0]],
            k,
            compensator,
            unloaded_positions=campaign.p0[rows],
            load_point=load_point if campaign.load_point is None else campaign.load_point[rows[0]],
            compensated_joint=equations.joint,
        )
    per_row = np.repeat(np.asarray(compliances, dtype=float)[None, :], equations.n, axis=0)
    if equations.joint is not None:
        per_row[:, equations.joint] = k2[equations.angle]
    return exact.reshape(-1) - np.einsum("ij,ij->i", equations.design, per_row)


def _timed_fit(cell, campaign):
    import time

    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler

    began, cpu = time.perf_counter(), time.process_time()
    results = ElastostaticModel.from_cell(cell, sampler=elastostatic_sampler(**SAMPLER)).fit(campaign, 0)
    return results, time.perf_counter() - began, time.process_time() - cpu


def measure(n: int, config: Path, baseline: bool) -> None:
    """Simulate, fit and print one line for a campaign of ``n`` configurations (run in a process of its own)."""
    import resource
    import time
    import warnings
    from unittest import mock

    import numpy as np

    from bayescal.cell.config import load_cell
    from bayescal_studies.studies.elastostatic_coverage import random_plan
    from bayescal.twin.simulator import DigitalTwin

    warnings.simplefilter("ignore")
    cell = load_cell(config)
    rng = np.random.default_rng(n)
    plan = random_plan(cell, n, 1, rng)
    began = time.process_time()
    campaign = DigitalTwin(cell).simulate(plan, 1, rng)
    simulated = time.process_time() - began
    results, wall, cpu = _timed_fit(cell, campaign)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    line = (
        f"{n:7d} configurations {campaign.n_equations:7d} equations  fit {wall:6.1f} s wall {cpu:6.1f} s CPU  "
        f"peak memory {peak:5.0f} MB  R-hat max {results.diagnostics()['r_hat_max']:.3f}  (simulation {simulated:.1f} s CPU)"
    )
    if baseline:
        with mock.patch("bayescal.inference.exact.linearisation_offset", loop_offset):
            looped, loop_wall, loop_cpu = _timed_fit(cell, campaign)
        mine, theirs = results.summary(), looped.summary()
        moved = float(np.max(np.abs(mine["mean"] - theirs["mean"]) / theirs["sd"]))
        line += f"\n        baseline loop: {loop_wall:6.1f} s wall {loop_cpu:6.1f} s CPU; ratio {loop_cpu / cpu:5.1f}x CPU; means differ by ≤ {moved:.1e} sd"
    print(line, flush=True)


def equilibrium_costs(config: Path, n: int = 20000, looped: int = 500) -> None:
    """Print the CPU time of one loaded equilibrium solved by :func:`bayescal.robot.batched.equilibria` for ``n``
    configurations at once, against :meth:`ElasticArm.equilibrium <bayescal.robot.stiffness.ElasticArm.equilibrium>`
    one configuration after another (the first ``looped`` of them)."""
    import time

    import numpy as np

    from bayescal.cell.config import load_cell
    from bayescal.robot.batched import BatchedChain, equilibria
    from bayescal.robot.stiffness import ElasticArm
    from bayescal_studies.studies.elastostatic_coverage import random_plan

    cell = load_cell(config)
    q = random_plan(cell, n, 1, np.random.default_rng(0)).q
    wrench = cell.load_wrench(q[0], cell.load_mass)
    options = dict(compensator=cell.compensator, compensated_joint=cell.compensated_joint, load_point=cell.load_point)
    arm = ElasticArm.linear(cell.robot, cell.compliances, **options)
    began = time.process_time()
    for qi in q[:looped]:
        arm.equilibrium(qi, wrench)
    loop = (time.process_time() - began) / looped
    began = time.process_time()
    equilibria(BatchedChain.of(cell.robot), q, wrench, cell.compliances, **options)
    batched = (time.process_time() - began) / n
    print(f"one equilibrium: {batched * 1e6:.1f} μs CPU batched ({n:,} configurations), {loop * 1e6:.0f} μs in a loop; ratio {loop / batched:.0f}x")


def loop_simulate(twin, plan, repeats: int, rng):
    """BASELINE: :meth:`DigitalTwin.simulate <bayescal.twin.simulator.DigitalTwin.simulate>`'s readings as it made them,
    two equilibria solved and the tracker read for one configuration after another; ``(p0, p1)`` in the campaign's row order."""
    import numpy as np

    p0, p1 = [], []
    for q, wrench in zip(plan.q, plan.wrenches(twin.cell)):
        unloaded, loaded = twin._positions(q, wrench)
        for _ in range(repeats):
            p0.append(twin.cell.tracker.measure(unloaded, rng))
            p1.append(twin.cell.tracker.measure(loaded, rng))
    return np.vstack(p0), np.vstack(p1)


def simulation_costs(n: int, config: Path, looped: int) -> None:
    """Print the CPU time and the peak memory of this process for the twin's simulation of ``n`` random configurations
    (one repeat), against the per-configuration loop on the first ``looped`` (scaled), and how far their readings differ."""
    import resource
    import time

    import numpy as np

    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import Plan
    from bayescal_studies.studies.elastostatic_coverage import random_plan
    from bayescal.twin.simulator import DigitalTwin

    cell = load_cell(config)
    plan = random_plan(cell, n, 1, np.random.default_rng(n))
    twin = DigitalTwin(cell)
    began, cpu = time.perf_counter(), time.process_time()
    campaign = twin.simulate(plan, 1, np.random.default_rng(0))
    wall, cpu = time.perf_counter() - began, time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    head = Plan(q=plan.q[:looped], load_kg=None if plan.load_kg is None else plan.load_kg[:looped], lines=plan.lines[:looped], source=plan.source)
    began = time.process_time()
    p0, p1 = loop_simulate(twin, head, 1, np.random.default_rng(0))
    loop = (time.process_time() - began) / looped * n
    rows = len(p0)
    moved = max(np.abs(campaign.p0[:rows] - p0).max(), np.abs(campaign.p1[:rows] - p1).max())
    print(
        f"simulate {n:,} configurations: {cpu:.2f} s CPU ({wall:.2f} s wall), peak memory of the process {peak:.0f} MB; "
        f"the per-configuration loop {loop:.1f} s CPU (timed on {looped:,}, scaled; {loop / cpu:.0f}x); "
        f"readings equal to {moved:.1e} m",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=sized([1000, 10000, 100000], [20]))
    parser.add_argument("--baseline-max", type=int, default=10000, help="largest size also fitted with the baseline loop")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--simulate", type=int, default=sized(100_000, 20), help="configurations of the simulation timed alone (0 leaves it out)")
    parser.add_argument("--simulation", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    config = ROOT / "data" / "kr270.toml"
    if args.simulation:
        simulation_costs(args.simulate, config, sized(2_000, 5))
        return
    if args.one:
        measure(args.sizes[0], config, args.sizes[0] <= args.baseline_max)
        return
    equilibrium_costs(config, *sized((), (50, 5)))
    if args.simulate:
        # a process of its own, so that its peak memory is the simulation's
        done = subprocess.run([sys.executable, __file__, "--simulation", "--simulate", str(args.simulate)], capture_output=True, text=True)
        print(done.stdout.strip() or f"simulate failed: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
    for n in args.sizes:
        done = subprocess.run(
            [sys.executable, __file__, "--one", str(n), "--baseline-max", str(args.baseline_max)], capture_output=True, text=True
        )
        print(done.stdout.strip() or f"{n:7d} configurations failed: {(done.stderr.strip().splitlines() or ['?'])[-1]}")


if __name__ == "__main__":
    main()
