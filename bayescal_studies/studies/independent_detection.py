"""The critique and the lack-of-fit test on campaigns of the independent generator.

:func:`independent_detection` runs the critique of :func:`~bayescal_studies.studies.detection.detection_power`
on campaigns of the independent generator (:mod:`bayescal.twin.independent`: its own equilibrium,
truths drawn unlike the cell, effects in forms of its own), whose rules were
never set on it; :func:`independent_rates` sums them up against the detection
targets, with the lack-of-fit test's size and power.  :func:`independent_lack_of_fit`
fits only the calibration's model to the same campaigns at several multiples of each
effect's default, and :func:`lack_of_fit_power` tabulates the test's size and power
against magnitude.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from os import PathLike

import numpy as np
import pandas as pd

__all__ = [
    "INDEPENDENT_EFFECTS",
    "INDEPENDENT_FIRST_SEED",
    "LACK_OF_FIT_SIZE_LEVEL",
    "independent_detection",
    "independent_rates",
    "POWER_MULTIPLES",
    "independent_lack_of_fit",
    "lack_of_fit_power",
]

INDEPENDENT_EFFECTS: dict[str, float] = {
    "link_beams": 1.0,
    "tool_mount": 1.0,
    "gear_play": 1.0,
    "approach_play": 1.0,
    "knee_joints": 1.0,
    "los_jumps": 1.0,
    "thermal_drift": 3.0,
    "random_field": 1.0,
}
"""The independent generator's effects and the multiple of each one's default at which the critique is held to
the detection targets, which apply to "each effect at a magnitude whose lack of fit is significant".

One rule for all, fixed before the power was measured: the smallest multiple in {1, 1.5, 2, 3} at which the
calibration model's lack-of-fit test rejects at 5 % in at least 95 % of 40 campaigns (seeds 9000-9039,
:func:`independent_lack_of_fit`); the default where none does.  Measured (docs/critique.md): ``link_beams``,
``knee_joints`` and ``random_field`` 100 % at their defaults, ``tool_mount`` 97.5 %; ``thermal_drift`` 62.5 %
at its default, 82.5 % at 1.5, 90 % at 2 and 100 % at 3, hence 3 (its cycle differs between repeats and inflates
the pure error, its steady part is partly taken up by the compliances); ``gear_play`` (10-15 %), ``approach_play``
(25-37.5 %) and ``los_jumps`` (2.5 %) at no multiple tried (their repeats disagree, which inflates the pure
error): they stay at their defaults, where that condition does not hold and the critique is held to the
thresholds all the same.  The rule chooses the test condition only; no rule or threshold of the critique was
set on this generator, but the lost-motion family's settings (friction hold, side on arrival) were added after
diagnosing ``gear_play`` and ``approach_play``, whose rates therefore no longer measure them out of sample
(docs/critique.md).  Left out:
``stiff_spring`` (3.8 μm at its default), ``load_rehang`` (11 μm) and ``tracker_scale`` (no deflection campaign
can see a scale error)."""

INDEPENDENT_FIRST_SEED = 9000
"""Seed of the first campaign of each case: campaign ``k`` is seeded ``INDEPENDENT_FIRST_SEED + k``
(a plan of :func:`~bayescal.twin.independent.random_plan`, then the generator, from one generator)."""

LACK_OF_FIT_SIZE_LEVEL = 0.05
"""Level at which the lack-of-fit test's size and power are counted."""


def _independent_campaign(effect: str | None, magnitude: float, rng: np.random.Generator, cell):
    """One campaign of the independent generator and its truth: a random plan, 3 repeats, ``effect`` at ``magnitude``."""
    from bayescal.twin.independent import IndependentGenerator, random_plan

    return IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), 3, effect, magnitude)


def _independent_one(case: tuple, rng: np.random.Generator, cell) -> dict:
    """The critique of one campaign of the independent generator (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
    from bayescal.critique import Critique

    effect, magnitude, seed = case
    campaign, truth = _independent_campaign(effect, magnitude, rng, cell)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        result = Critique(cell).run(campaign)
        # the calibration model's own lack of fit, before any extension: the test's size and power
        classical = Critique(cell, catalogue=(), probes=()).run(campaign).lack_of_fit
    causes = list(result.causes)
    first = causes[0] if causes else None
    expected = truth.expected
    tie = result.tied_with.get(first, []) if first else []
    contest = result.contested_by.get(first, []) if first else []
    if expected == "adequate":
        right = alone = not causes
    elif expected == "unexplained":
        right, alone = "unexplained" in causes, causes == ["unexplained"]
    else:
        right, alone = first == expected or expected in tie + contest, first == expected and not tie and not contest
    lof = result.lack_of_fit
    return {
        "effect": effect or "none",
        "magnitude": magnitude,
        "seed": seed,
        "expected": expected,
        "verdict": result.verdict,
        "causes": ",".join(causes),
        "tied_with": ";".join(f"{k}:{'+'.join(v)}" for k, v in result.tied_with.items()),
        "right": right,
        "alone": alone,
        "wrong_single": bool(causes) and not right and not tie and not contest,
        "contested_by": ";".join(f"{k}:{'+'.join(v)}" for k, v in result.contested_by.items()),
        "negligible": ",".join(result.negligible),
        "drift_testable": bool(result.drift.get("testable")),
        "lof_p": np.nan if lof is None else float(lof.p_value),
        "classical_lof_p": np.nan if classical is None else float(classical.p_value),
    }


def independent_detection(
    config: str | PathLike[str],
    effects: Mapping[str, float] = INDEPENDENT_EFFECTS,
    *,
    n_seeds: int = 40,
    n_null: int = 40,
    first_seed: int = INDEPENDENT_FIRST_SEED,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """The critique's verdict on campaigns of the independent generator, one row per campaign.

    Parameters
    ----------
    config
        The cell TOML around which the generator draws its truths.
    effects
        Effect name to its magnitude (a multiple of the effect's default).
    n_seeds, n_null
        Campaigns per effect, and without any effect.
    first_seed
        Campaign ``k`` of every case is seeded ``first_seed + k``.
    executor
        Runs the campaigns; default a :class:`concurrent.futures.ProcessPoolExecutor`.

    Returns
    -------
    pandas.DataFrame
        ``effect, magnitude, seed, expected, verdict, causes, tied_with, right, alone, wrong_single, contested_by, negligible,
        drift_testable, lof_p``:
        ``right`` when the first cause is the planted family or ties with it, when an effect
        outside the catalogue is called ``unexplained``, or when a campaign without an effect is
        adequate, or contested by the planted family; ``alone`` when right without a tie or a contest (and
        ``unexplained`` the only cause); ``wrong_single`` a misfit whose first cause is wrong, tied with nothing
        and contested by nothing; ``contested_by`` the candidates contesting each named cause; ``negligible`` the
        named causes too small to matter; ``drift_testable`` whether the campaign's repeated readings can show a drift;
        ``lof_p`` the lack-of-fit test's p-value against the repeats for the final model,
        ``classical_lof_p`` for the calibration's model alone (no extension).
    """
    from bayescal.cell.config import load_cell
    from bayescal.design.parallel import seeded_map

    cases = [(None, 0.0, n_null)] + [(name, float(magnitude), n_seeds) for name, magnitude in effects.items()]
    tasks = [(name, magnitude, first_seed + k) for name, magnitude, n in cases for k in range(n)]
    # campaign k of every case draws from the generator seeded first_seed + k, whatever the executor
    streams = [np.random.SeedSequence(seed) for _, _, seed in tasks]
    return pd.DataFrame.from_records(seeded_map(_independent_one, tasks, streams, executor=executor, cell=load_cell(config)))


def independent_rates(table: pd.DataFrame) -> pd.DataFrame:
    """Per effect and magnitude (``none`` first): campaigns, and the fractions misfit, right, right alone, wrong single cause, and the
    calibration model's lack of fit at :data:`LACK_OF_FIT_SIZE_LEVEL` (its size on ``none``, its power on the effects)."""
    rows = []
    for (effect, magnitude), group in table.groupby(["effect", "magnitude"], sort=False):
        rows.append(
            {
                "effect": effect,
                "magnitude": float(magnitude),
                "expected": group["expected"].iloc[0],
                "n": len(group),
                "misfit": float(np.mean(group["verdict"] == "misfit")),
                "right": float(np.mean(group["right"])),
                "alone": float(np.mean(group["alone"])),
                "wrong_single": float(np.mean(group["wrong_single"])),
                "lack_of_fit": float(np.mean(group["classical_lof_p"] < LACK_OF_FIT_SIZE_LEVEL)),
            }
        )
    return pd.DataFrame.from_records(rows)


POWER_MULTIPLES: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 3.0)
"""Multiples of each effect's default at which :func:`independent_lack_of_fit` measures the test's power."""


def _lack_of_fit_one(case: tuple, rng: np.random.Generator, cell) -> dict:
    """The calibration model's lack-of-fit test on one campaign of the independent generator (a task of
    :func:`~bayescal.design.parallel.seeded_map`): the campaign :func:`_independent_one` critiques for the same seed."""
    from bayescal.critique import Critique

    effect, magnitude, seed = case
    campaign, _ = _independent_campaign(effect, magnitude, rng, cell)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        test = Critique(cell, catalogue=(), probes=()).run(campaign).lack_of_fit
    dof = (np.nan, np.nan) if test is None else test.dof
    return {
        "effect": effect or "none",
        "multiple": magnitude,
        "seed": seed,
        "statistic": np.nan if test is None else test.statistic,
        "p_value": np.nan if test is None else test.p_value,
        "dof_lof": dof[0],
        "dof_pe": dof[1],
        "null_mean": np.nan if test is None else test.null_mean,
    }


def independent_lack_of_fit(
    config: str | PathLike[str],
    effects: Sequence[str] = tuple(INDEPENDENT_EFFECTS),
    multiples: Sequence[float] = POWER_MULTIPLES,
    *,
    n_seeds: int = 40,
    n_null: int = 40,
    first_seed: int = INDEPENDENT_FIRST_SEED,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """The calibration model's lack-of-fit test on campaigns of the independent generator, one row per campaign.

    The campaigns are those of :func:`independent_detection` (campaign ``k`` of each case seeded
    ``first_seed + k``), but only the calibration's model is fitted (the critique with an empty
    catalogue), so that the test's power can be traced over many magnitudes cheaply.

    Parameters
    ----------
    config
        The cell TOML around which the generator draws its truths.
    effects
        The generator's effects to plant.
    multiples
        Magnitudes of each effect, as multiples of its default.
    n_seeds, n_null
        Campaigns per effect and multiple, and without any effect (its size).
    first_seed
        Seed of the first campaign of each case.
    executor
        Runs the campaigns; default a :class:`concurrent.futures.ProcessPoolExecutor`.

    Returns
    -------
    pandas.DataFrame
        ``effect, multiple, seed, statistic, p_value, dof_lof, dof_pe, null_mean`` (effect ``none``,
        multiple 0, for the campaigns without an effect; ``null_mean`` the statistic's mean under the
        model; NaN where the campaign has no repeats).
    """
    from bayescal.cell.config import load_cell
    from bayescal.design.parallel import seeded_map

    cases = [(None, 0.0, n_null)] + [(name, float(m), n_seeds) for name in effects for m in multiples]
    tasks = [(name, multiple, first_seed + k) for name, multiple, n in cases for k in range(n) if n]
    streams = [np.random.SeedSequence(seed) for _, _, seed in tasks]
    return pd.DataFrame.from_records(seeded_map(_lack_of_fit_one, tasks, streams, executor=executor, cell=load_cell(config)))


def lack_of_fit_power(table: pd.DataFrame) -> pd.DataFrame:
    """Per effect and multiple (``none`` first): campaigns, the fractions with ``p < 0.05`` and ``p < 0.01``, and the mean F.

    On ``none`` the fractions are the test's size; ``expected_statistic`` is the statistic's mean under
    the model averaged over the campaigns.
    """
    rows = []
    for (effect, multiple), group in table.groupby(["effect", "multiple"], sort=False):
        rows.append(
            {
                "effect": effect,
                "multiple": float(multiple),
                "n": len(group),
                "at_5": float(np.mean(group["p_value"] < 0.05)),
                "at_1": float(np.mean(group["p_value"] < 0.01)),
                "mean_statistic": float(group["statistic"].mean()),
                "expected_statistic": float(group["null_mean"].mean()),
            }
        )
    return pd.DataFrame.from_records(rows)
