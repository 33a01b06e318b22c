"""Effective samples per second of the default (collapsed) sampler against NUTS (NumPyro) on the same posterior.

The Table III campaign simulated on the digital twin (15 configurations, 3
repeats, seed 1) is fitted in this process by ``ElastostaticModel`` (exact
model, compensator geometry from the cell's Table II prior), for each seed once
with the default sampler and twice with :class:`jax_posterior.NutsSampler` in
its place (NumPyro's default diagonal mass matrix, then a dense one): the model,
its equations and the posterior the sampler is given are the same.  Before
sampling, the JAX log density that NUTS follows is compared with the package's
at the start, at draws of the default sampler and at points 3 sd around the
start (the largest absolute difference is printed; the script stops if it
exceeds :data:`DENSITY_TOLERANCE`).

Each line gives the wall and CPU time of the whole ``fit`` and of the sampler's
``sample`` call alone, the smallest bulk and tail ESS over every reported
parameter but the noise levels (ArviZ-style, all chains), the largest R-hat, and
the smallest bulk ESS per second of sampling (wall; the ratios are also given per
CPU second of this process, steadier on a shared machine); each NUTS fit's draws are
compared with the default's (means and sd, in the default's sd).  NUTS's time
includes JAX's tracing and compilation of its kernel, which a user pays on every
fit of a new campaign, and NumPyro's initial state of each chain; the ratio
"without compilation" counts only the compiled chains' running time, the most
favourable figure for NUTS.  BLAS runs on one thread (as in
``bench_samplers.py``); XLA keeps its default threads.  Needs the ``bench``
extra (``pip install -e '.[bench]'``).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import jax.numpy as jnp  # noqa: E402
from jax_posterior import NutsSampler, log_density  # noqa: E402

from bayescal.cell.config import load_cell  # noqa: E402
from bayescal.cell.plan import read_plan  # noqa: E402
from bayescal.inference.elastostatic import ElastostaticModel  # noqa: E402
from bayescal.inference.samplers import elastostatic_sampler  # noqa: E402
from bayescal.twin.simulator import DigitalTwin  # noqa: E402
from smoke import SAMPLER, sized  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "data"
REPEATS = 3
SEEDS = sized((0, 1, 2), (0,))
"""Seeds of the fits; each sampler is run once per seed."""
DENSITY_TOLERANCE = 1e-9
"""Largest absolute difference (nats) allowed between the two log densities of about 3,700 nats, both
in double precision (measured: 4.6e-13)."""


@dataclass
class Timed:
    """A sampler that times its inner sampler's ``sample`` call and keeps what it was given."""

    inner: object
    seconds: float = 0.0
    cpu: float = 0.0
    given: dict = field(default_factory=dict)

    def sample(self, target, start, scale, rng):
        self.given = {"target": target, "start": start, "scale": scale}
        began, cpu = time.perf_counter(), time.process_time()
        draws = self.inner.sample(target, start, scale, rng)
        self.seconds, self.cpu = time.perf_counter() - began, time.process_time() - cpu
        self.given["draws"] = draws
        return draws


def fit(cell, campaign, sampler, seed: int) -> tuple[Timed, dict[str, float]]:
    """Fit ``campaign`` with ``sampler``; the timings and the diagnostics of the reported parameters."""
    timed = Timed(sampler)
    model = ElastostaticModel.from_cell(cell, sampler=timed)
    began, cpu = time.perf_counter(), time.process_time()
    summary = model.fit(campaign, seed).summary()
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    summary = summary.drop([n for n in summary.index if n.startswith("sigma")])
    return timed, {
        "fit": seconds,
        "fit_cpu": cpu,
        "bulk": float(summary["ess_bulk"].min()),
        "worst": str(summary["ess_bulk"].idxmin()),
        "tail": float(summary["ess_tail"].min()),
        "r_hat": float(summary["r_hat"].max()),
    }


def check_density(given: dict) -> float:
    """The largest absolute difference between the JAX and the package's log density at 21 points."""
    posterior, start, scale = given["target"], given["start"], given["scale"]
    draws = given["draws"].reshape(-1, start.size)
    rng = np.random.default_rng(0)
    points = [start, *draws[rng.choice(draws.shape[0], 10, replace=False)]]
    points += [start + 3.0 * scale * rng.standard_normal(start.size) for _ in range(10)]
    jax_density = log_density(posterior)
    return max(abs(float(jax_density(jnp.asarray(x))) - posterior(x)) for x in points if np.isfinite(posterior(x)))


def line(name: str, seed: int, timed: Timed, result: dict[str, float], draws: int) -> str:
    return (
        f"{name:<16} seed {seed}  fit {result['fit']:6.2f} s wall, {result['fit_cpu']:6.2f} s CPU; sampling "
        f"{timed.seconds:6.2f} s wall, {timed.cpu:6.2f} s CPU, {draws:6d} draws  min bulk ESS {result['bulk']:6.0f} "
        f"({result['worst']})  min tail ESS {result['tail']:6.0f}  R-hat max {result['r_hat']:.4f}  "
        f"bulk ESS per sampling second {result['bulk'] / timed.seconds:8.1f}"
    )


def agreement(reference: np.ndarray, other: np.ndarray) -> str:
    """How far ``other``'s draws ``(chain, draw, ndim)`` lie from ``reference``'s, in ``reference``'s sd."""
    reference, other = (d.reshape(-1, d.shape[-1]) for d in (reference, other))
    sd = reference.std(axis=0)
    shift = np.max(np.abs(other.mean(axis=0) - reference.mean(axis=0)) / sd)
    ratio = other.std(axis=0) / sd
    return f"means within {shift:.3f} sd of the default's, sd {ratio.min():.3f}-{ratio.max():.3f} times the default's"


def run_nuts(cell, campaign, sampler: NutsSampler, name: str, seed: int, default: Timed, rates: dict[str, list[float]]) -> None:
    """Fit with NUTS, print its lines and append its two rates."""
    nuts, result = fit(cell, campaign, sampler, seed)
    record = sampler.record
    print(line(name, seed, nuts, result, sampler.n_chains * sampler.n_draws))
    rates.setdefault(name, []).append(result["bulk"] / nuts.seconds)
    rates.setdefault(f"{name} per CPU second", []).append(result["bulk"] / nuts.cpu)
    rates.setdefault(f"{name} without compilation", []).append(result["bulk"] / record["loop_seconds"])
    print(
        f"{'':<16} seed {seed}  initial states {record['init_seconds']:.2f} s, compilation {record['compile_seconds']:.2f} s, "
        f"chains {record['loop_seconds']:.2f} s (bulk ESS per second of the chains {rates[f'{name} without compilation'][-1]:.1f}); "
        f"{record['gradients'] / (sampler.n_chains * sampler.n_draws):.1f} gradients per kept draw, {record['divergences']} divergences; "
        f"{agreement(default.given['draws'], nuts.given['draws'])}"
    )


def main() -> None:
    warnings.simplefilter("ignore")
    cell = load_cell(DATA / "kr270.toml")
    plan = read_plan(DATA / "table3_plan.csv", cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, REPEATS, np.random.default_rng(1))
    rates: dict[str, list[float]] = {"default": [], "default per CPU second": []}
    for seed in SEEDS:
        default, result = fit(cell, campaign, elastostatic_sampler(**SAMPLER), seed)
        draws = default.given["draws"]
        print(line("default", seed, default, result, draws.shape[0] * draws.shape[1]))
        rates["default"].append(result["bulk"] / default.seconds)
        rates["default per CPU second"].append(result["bulk"] / default.cpu)
        difference = check_density(default.given)
        print(f"{'':<16} seed {seed}  JAX against the package's log density at 21 points: largest difference {difference:.2e} nats")
        if not difference <= DENSITY_TOLERANCE:
            sys.exit(f"the JAX log density differs from the package's by {difference:.3g} nats: NUTS would sample another posterior")
        nuts_size = sized({}, dict(n_chains=1, n_warmup=10, n_draws=10))
        run_nuts(cell, campaign, NutsSampler(**nuts_size), "NUTS", seed, default, rates)
        run_nuts(cell, campaign, NutsSampler(dense_mass=True, **nuts_size), "NUTS dense mass", seed, default, rates)
    for name in [n for n in rates if not n.startswith("default")]:
        reference = np.median(rates["default per CPU second" if name.endswith("per CPU second") else "default"])
        unit = "CPU" if name.endswith("per CPU second") else "wall"
        print(
            f"median over {len(SEEDS)} seeds, min bulk ESS per {unit} second of sampling, default over {name}: "
            f"{reference / np.median(rates[name]):.1f} ({reference:.0f} against {np.median(rates[name]):.0f})"
        )


if __name__ == "__main__":
    main()
