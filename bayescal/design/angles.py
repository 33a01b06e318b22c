"""What each extra q2 angle buys: predicted ±3σ widths against the number of angles and configurations.

For every number of distinct q2 angles and of configurations per angle, a
plan is designed for one criterion (:class:`~bayescal.design.optimise.PlanDesigner`,
the exchange step alone from one shared candidate set, exact model) and its
predicted precision is tabulated at the cell's tracker noise and at a
fraction of it.  The noise enters the information matrix only as the factor
``1/σ²``, so a plan optimal at one noise level is optimal at every level and
the widths scale with the noise: the second level is the same plan's
prediction with every standard deviation multiplied by the fraction.

:func:`identification_cost` turns the table into the question users ask
first: what would identify K_c and s0 to a given width.  Widths fall as
``1/√repeats`` and in proportion to the noise, which gives the repeats or the
noise needed when no tabulated plan reaches the target.

Plans are designed on a :class:`concurrent.futures.Executor`, one task per
(angles, configurations) pair; seeds are spawned from one
:class:`numpy.random.SeedSequence`, so the table does not depend on the number
of workers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.design.optimise import CANDIDATES_PER_ANGLE, PlanDesigner
from bayescal.errors import InputError
from bayescal.inference.parameters import ParameterRegistry
from bayescal.robot.compensator import MIN_ANGLES
from bayescal.design.parallel import seeded_map
from bayescal.units import MM

__all__ = ["FIXED_TARGET_PCT", "identification_cost", "q2_angle_study", "width_targets"]

FIXED_TARGET_PCT = 5.0
"""A width (±3σ in % of the value) of K_c and s0 asked of every cell, published or not."""

NOISE_FRACTIONS = (1.0, 0.1)
"""Tracker noise levels of the study, as fractions of the cell's."""


def _design(pair: tuple[int, int], rng: np.random.Generator, designer: PlanDesigner, candidates, criterion: str) -> list[dict]:
    """One task of :func:`~bayescal.design.parallel.seeded_map`: the plan for (angles, per_angle) and its
    prediction at each noise level."""
    angles, per_angle = pair
    design = designer.optimise(angles, per_angle, criterion, rng=rng, starts=1, refine_steps=0, candidates=candidates)
    prediction = design.prediction
    rows = []
    for fraction in NOISE_FRACTIONS:
        row = {"angles": angles, "per_angle": per_angle, "noise_fraction": fraction, "test_pose_rms_mm": fraction * prediction.rho0 / MM}
        row |= {f"{name}_width_3sd_pct": 300.0 * fraction * sd for name, sd in zip(prediction.names, prediction.relative_sd)}
        rows.append(row)
    return rows


def q2_angle_study(
    cell: Cell,
    *,
    angles: Sequence[int] = range(3, 13),
    per_angle: Sequence[int] = range(1, 6),
    criterion: str = "compensator",
    repeats: int = 3,
    seed: int = 0,
    candidates_per_angle: int = CANDIDATES_PER_ANGLE,
    executor: Executor | None = None,
    progress: bool = False,
) -> pd.DataFrame:
    """Predicted ±3σ widths of every parameter and the test-pose rms error per plan size.

    Parameters
    ----------
    cell
        The cell.
    angles
        Numbers of distinct q2 angles (the compensator's three joint-2 parameters need at least 3).
    per_angle
        Numbers of configurations per angle.
    criterion
        What each plan is designed for.
    repeats
        Measurements of each configuration.
    seed
        Root of the seeds (candidate set and each design).
    candidates_per_angle
        Candidate configurations at each q2 of the grid.
    executor
        Where the designs run; default a process pool on all cores.
    progress
        Draw a progress bar of the plans designed on stderr (a terminal only), with the remaining time measured on them.

    Returns
    -------
    pandas.DataFrame
        One row per (angles, per_angle, noise_fraction): ``test_pose_rms_mm`` and
        ``<parameter>_width_3sd_pct`` (NaN for a parameter the plans do not excite).
    """
    angles, per_angle = list(angles), list(per_angle)
    if min(angles) < MIN_ANGLES and cell.compensator is not None:
        raise InputError(f"K_c and s0 need at least {MIN_ANGLES} distinct q2 angles, got {min(angles)}", source="angles")
    designer = PlanDesigner(cell, repeats=repeats, model="exact")
    # Before the seeds (one per plan: the million of --max-per-angle 100000 took 5 s of CPU) and the candidates
    # (most of a minute): the largest plan refused here is refused by every design.
    designer.check_request(max(angles), max(per_angle), criterion, candidates_per_angle=candidates_per_angle)
    root = np.random.SeedSequence(seed)
    candidate_seed, *design_seeds = root.spawn(1 + len(angles) * len(per_angle))
    candidates = designer.candidates(np.random.default_rng(candidate_seed), per_angle=candidates_per_angle)
    pairs = [(a, c) for a in angles for c in per_angle]
    results = seeded_map(
        _design, pairs, design_seeds, executor=executor, progress="study: plans" if progress else None,
        designer=designer, candidates=candidates, criterion=criterion,
    )
    return pd.DataFrame([row for rows in results for row in rows])


def width_targets(cell: Cell) -> dict[str, dict[str, float]]:
    """The widths of K_c and s0 (±3σ in % of the value) to reach: the cell's published ones, and 5 %.

    The published widths are those of the cell's reference table (Klimchik et al.'s
    Table IV for the KR-270, :class:`~bayescal.inference.parameters.ParameterRegistry`);
    a cell that publishes none gets the 5 % target alone.
    """
    registry = ParameterRegistry.of_cell(cell)
    published = {name: registry[name].published for name in ("K_c", "s0") if registry.compensated}
    targets = {}
    if published and all(published.values()):
        targets["Table IV"] = {name: 100.0 * half_width / value for name, (value, half_width) in published.items()}
    return targets | {f"{FIXED_TARGET_PCT:g} %": {"K_c": FIXED_TARGET_PCT, "s0": FIXED_TARGET_PCT}}


def identification_cost(table: pd.DataFrame, *, targets: dict[str, dict[str, float]], repeats: int = 3) -> pd.DataFrame:
    """What would identify K_c and s0 to each target width, from :func:`q2_angle_study`'s table.

    Parameters
    ----------
    table
        :func:`q2_angle_study`'s table.
    targets
        Label to the ±3σ widths of K_c and s0 to reach (% of the value), as :func:`width_targets` gives.
    repeats
        Measurements of each configuration in the study.

    Returns
    -------
    pandas.DataFrame
        One row per target and noise level: the smallest plan (fewest configurations)
        reaching it at ``repeats`` repeats, or, when none does, the best plan of the
        table (largest K_c and s0 shortfall smallest) with ``repeats_needed`` (widths
        fall as 1/√repeats) and ``noise_fraction_needed`` (widths scale with the noise).
    """
    rows = []
    for label, goal in targets.items():
        for fraction, group in table.groupby("noise_fraction", sort=False):
            ratio = np.maximum(group["K_c_width_3sd_pct"] / goal["K_c"], group["s0_width_3sd_pct"] / goal["s0"])
            reached = group[ratio <= 1.0]
            if len(reached):
                best = reached.loc[(reached["angles"] * reached["per_angle"]).sort_values(kind="stable").index[0]]
                shortfall = float(max(best["K_c_width_3sd_pct"] / goal["K_c"], best["s0_width_3sd_pct"] / goal["s0"]))
            else:
                best = group.loc[ratio.idxmin()]
                shortfall = float(ratio.min())
            rows.append(
                {
                    "target": label,
                    "noise_fraction": fraction,
                    "reached": bool(len(reached)),
                    "angles": int(best["angles"]),
                    "per_angle": int(best["per_angle"]),
                    "K_c_width_3sd_pct": float(best["K_c_width_3sd_pct"]),
                    "s0_width_3sd_pct": float(best["s0_width_3sd_pct"]),
                    "repeats_needed": repeats if shortfall <= 1.0 else int(math.ceil(repeats * shortfall**2)),
                    "noise_fraction_needed": float(fraction) * min(1.0, 1.0 / shortfall),
                }
            )
    return pd.DataFrame(rows)
