"""How far the identification's residuals rise above the noise with each effect of the independent generator.

For every effect (and none) and every seed: a random plan (6 q2 angles × 5
configurations, 200-300 kg), a campaign of 3 repeats from
:class:`~bayescal.twin.independent.IndependentGenerator` with a drawn truth, its
anisotropic tracker noise and the effect at ``magnitude``, and the elastostatic fit
of ``bayescal calibrate`` (exact model, default sampler) with the model built from
the unchanged cell.  The same campaign without noise and without the effect gives
what the effect changes.  No model criticism is run and no threshold is set here.
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Sequence
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.errors import InputError
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.design.parallel import seeded_map
from bayescal.twin.independent import EFFECTS, IndependentGenerator, random_plan

__all__ = ["effect_residuals"]


def _campaign(cell: Cell, rng: np.random.Generator, effect: str | None, magnitude: float, noise: bool):
    plan = random_plan(cell, rng)
    return IndependentGenerator(cell, rng, noise=noise).simulate(plan, 3, effect, magnitude)[0]


def _fit(cell: Cell, campaign, seed: int) -> dict:
    """The fit's residuals and convergence, or the reason it refused the campaign."""
    try:
        with warnings.catch_warnings():
            # Identifiability and convergence warnings are the fit's, recorded in its diagnostics.
            warnings.simplefilter("ignore")
            results = ElastostaticModel.from_cell(cell).fit(campaign, rng=seed)
    except InputError as error:
        return dict.fromkeys(_FIT_COLUMNS, np.nan) | {"error": error.what}
    report = results.diagnostics()
    values = (results.residual_rms / 1e-6, results.chi2_per_dof, report["r_hat_max"], report["ess_bulk_min"])
    return dict(zip(_FIT_COLUMNS, values)) | {"error": None}


_FIT_COLUMNS = ("residual_rms_um", "chi2_per_dof", "r_hat_max", "ess_bulk_min")


def effect_residuals(
    cell: Cell,
    seeds: Sequence[int],
    *,
    magnitude: float = 1.0,
    effects: Sequence[str | None] | None = None,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """One row per effect and seed: what the effect changes and the fit's residuals, in μm.

    Parameters
    ----------
    cell
        The cell the campaigns are simulated in and identified with.
    seeds
        One campaign per seed and effect; the same seed gives the same plan and truth for every effect.
    magnitude
        Multiplier of every effect's default size.
    effects
        Effect names (None: no effect); all of :data:`~bayescal.twin.independent.EFFECTS` and None by default.
    executor
        Where the campaigns run (:func:`~bayescal.design.parallel.seeded_map`); default a process pool on all
        cores.  Seed ``s`` draws the stream of ``np.random.default_rng(s)``.

    Returns
    -------
    pandas.DataFrame
        Columns ``effect`` ("none" for no effect), ``cause``, ``seed``, ``change_um`` (rms change of
        the noiseless deflections), ``noise_um`` (rms of the cell's noise model on a deflection:
        the floor), ``residual_rms_um``, ``chi2_per_dof``, ``r_hat_max``, ``ess_bulk_min`` and
        ``error``: the message when the fit refuses the campaign (its other columns then NaN).
    """
    effects = [None, *EFFECTS] if effects is None else list(effects)
    items = [(effect, seed) for effect in effects for seed in seeds]
    streams = [np.random.SeedSequence(seed) for _, seed in items]
    rows = seeded_map(_row, items, streams, executor=executor, cell=cell, magnitude=magnitude)
    return pd.DataFrame(rows)


def _row(item: tuple[str | None, int], rng: np.random.Generator, *, cell: Cell, magnitude: float) -> dict:
    """One task of :func:`effect_residuals`: the campaign of one effect and seed, without noise and without the effect."""
    effect, seed = item
    # The noisy, the noiseless and the effect-free campaigns share the seed's plan and truth: three copies of one stream.
    campaign, exact, bare = (
        _campaign(cell, copy.deepcopy(rng), planted, magnitude, noisy)
        for planted, noisy in ((effect, True), (effect, False), (None, False))
    )
    change = np.sqrt(np.mean((exact.displacement - bare.displacement) ** 2))
    noise = np.sqrt(np.mean(cell.tracker.deflection_variance(campaign.p0, campaign.p1)))
    row = {
        "effect": effect or "none",
        "cause": EFFECTS[effect].cause if effect else None,
        "seed": seed,
        "change_um": change / 1e-6,
        "noise_um": noise / 1e-6,
    }
    return row | _fit(cell, campaign, seed)
