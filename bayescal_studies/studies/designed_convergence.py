"""Does the default calibration converge on the plans ``bayescal plan`` designs?

The workflow a user follows is: design a plan (``bayescal plan``), measure it, and
calibrate with the defaults (``bayescal calibrate``).  This study runs that
workflow end to end over several designs (criteria, sizes, seeds of the search):
each designed plan is measured twice, by the digital twin (as ``bayescal
simulate`` does) and by the independent generator (:mod:`bayescal.twin.independent`:
truths, tool and tracker noise drawn unlike the cell's, a solver of its own), and
each campaign is identified exactly as ``bayescal calibrate`` does
without options: the exact model, the default sampler's draws, extended up to
:data:`~bayescal.inference.elastostatic.EXTENSIONS` times while R-hat or the
ESS fall short.  The table says, per campaign, whether R-hat and the bulk and tail
ESS met :func:`bayescal.sampling.summary.converged`'s thresholds, with how
many draws and which sampler.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.design.optimise import STARTS, PlanDesigner
from bayescal.inference.elastostatic import EXTENSIONS, ElastostaticModel
from bayescal.inference.samplers import elastostatic_sampler
from bayescal.sampling.summary import converged
from bayescal.design.parallel import seeded_map
from bayescal.twin.independent import IndependentGenerator
from bayescal.twin.simulator import DigitalTwin

__all__ = ["Design", "designed_plan_convergence", "default_designs"]

REPEATS = 3
"""Measurements of each configuration, ``bayescal plan``'s and ``bayescal simulate``'s default."""


@dataclass(frozen=True)
class Design:
    """One request to ``bayescal plan``: what it optimises, the plan's size, the search's model and seed."""

    criterion: str = "test-pose"
    angles: int = 5
    per_angle: int = 3
    model: str = "linear"
    seed: int = 0


def default_designs(count: int, model: str = "linear", first_seed: int = 0) -> list[Design]:
    """``count`` requests cycling through the three criteria and three plan sizes, search seeds from ``first_seed`` on."""
    criteria = ("test-pose", "compensator", "d-optimal")
    sizes = ((5, 3), (4, 3), (6, 2))
    return [Design(criteria[i % 3], *sizes[(i // 3) % 3], model=model, seed=first_seed + i) for i in range(count)]


def designed_plan_convergence(cell: Cell, designs: Sequence[Design], seed: int, *, executor: Executor | None = None) -> pd.DataFrame:
    """Design each plan, measure it on the independent generator, calibrate with the defaults.

    Parameters
    ----------
    cell
        The cell the plans are designed for and the campaigns are drawn around.
    designs
        The ``bayescal plan`` requests, one campaign each.
    seed
        Root of the campaigns' random streams (truth, tool, noise).
    executor
        Where the campaigns run (default: a process pool on all cores).

    Returns
    -------
    pandas.DataFrame
        Two rows per design, ``generator`` ``"twin"`` and ``"independent"``: ``criterion, angles, per_angle, model, design_seed``, the
        plan's ``q2_deg`` (text), ``r_hat_max``, ``ess_bulk_min``, ``ess_tail_min``,
        ``n_draws`` (kept per chain, after any extension), ``sampler`` (the one that drew them), ``converged``, and the wall
        times ``design_s`` and ``calibrate_s``.
    """
    rows = seeded_map(_campaigns, list(designs), seed, executor=executor, cell=cell)
    return pd.DataFrame([row for pair in rows for row in pair])


def _campaigns(design: Design, rng: np.random.Generator, cell: Cell) -> list[dict]:
    start = time.perf_counter()
    planned = PlanDesigner(cell, repeats=REPEATS, model=design.model).optimise(
        design.angles, design.per_angle, design.criterion, rng=design.seed, starts=STARTS
    )
    designed = time.perf_counter() - start
    q2 = np.unique(np.round(np.degrees(planned.plan.q[:, cell.plan_joint]), 1))
    campaigns = {
        "twin": DigitalTwin(cell).simulate(planned.plan, REPEATS, rng),
        "independent": IndependentGenerator(cell, rng).simulate(planned.plan, REPEATS)[0],
    }
    rows = []
    for generator, campaign in campaigns.items():
        model = ElastostaticModel.from_cell(cell, model="exact", sampler=elastostatic_sampler(), extensions=EXTENSIONS)
        calibrating = time.perf_counter()
        with warnings.catch_warnings():
            # Not-identifiable parameters and extensions are warned about; the table records what matters here.
            warnings.simplefilter("ignore")
            results = model.fit(campaign, rng)
        report = results.diagnostics()
        rows.append(
            {
                "generator": generator,
                "criterion": design.criterion,
                "angles": design.angles,
                "per_angle": design.per_angle,
                "model": design.model,
                "design_seed": design.seed,
                "q2_deg": " ".join(f"{v:g}" for v in q2),
                "r_hat_max": report["r_hat_max"],
                "ess_bulk_min": report["ess_bulk_min"],
                "ess_tail_min": report["ess_tail_min"],
                "n_draws": report["n_draws"],
                "sampler": results.sampler_name,
                "converged": bool(converged(report)),
                "design_s": designed,
                "calibrate_s": time.perf_counter() - calibrating,
            }
        )
    return rows
