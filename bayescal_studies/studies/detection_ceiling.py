"""What a plan lets any candidate find: the naming rule applied to the planted effect's own shape.

The critique names a cause when a candidate's held-out gain clears the naming rule (:func:`~bayescal.critique.rule.passes`).
How often the planted cause is named has two limits: the candidate's form (a catalogue's family is not the planted
physics) and the plan (the effect's share of the deflections, beyond what the classical model already fits, against the
tracker's noise).  This study measures the second alone.  For a campaign with an effect planted and the campaign with
nothing planted of the same seed, the generators of :data:`~bayescal_studies.studies.critique_rates.GENERATORS` draw
the tracker's noise from streams the effect does not touch, so the difference of the two campaigns' deflections is the
effect's own, free of noise (the test checks it: a static effect differs by nothing between repeats).  Added to the
classical model as one column with a free amplitude, that *oracle* candidate has exactly the planted shape, which no
catalogue can beat; it is judged at the first step by the naming rule on held-out configurations, as every candidate is.
Where it is not named, no candidate is named for the reason the rule demands; the rate at which it is named bounds, but
for chance, the critique's first cause on that plan and noise (a candidate that fits noise too can pass where the oracle
does not), and what falls short of a target there is the plan's, not the method's.

The non-centrality λ says why: the planted share beyond the classical model's columns, as a χ² in the cell's tracker
noise.  Where the share is spread over the configurations, the oracle's held-out gain is about λ/2 nats with a standard
error of about √λ, and the rule's two standard errors ask λ/2 ≥ 2√λ: λ of about
:data:`~bayescal.critique.rule.SEPARABLE_CHI2` (16) is named in half the campaigns.  Where it sits in a few
configurations its standard error is larger, and the rule's decisive branch names it or nothing does.

What the right family's form sees of the share is measured beside it (``captured``): the largest fraction of λ that the
columns of one of its variants take up on top of the classical model.  A family captures less than the oracle with
more columns than its one, so a ceiling met by the oracle can still be out of a family's reach.  For
an effect whose shape is drawn at random (the tracker's drift, gross reading errors, where a play starts) the oracle
knows the draw, which no candidate can: there the ceiling is an upper bound only.
"""

from __future__ import annotations

import tempfile
import warnings
from collections.abc import Sequence
from concurrent.futures import Executor
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["planted_share", "detection_ceiling", "ceiling_rates"]


def planted_share(planted, none) -> np.ndarray:
    """(N, 3) m, the planted effect's share of each row's deflection: ``planted`` rows less ``none`` rows of the same seed.

    Both are :class:`~bayescal.critique.covariates.Rows` of campaigns that share every noise draw.  An effect that
    moves the arm's unloaded poses (a compensator 30 times too stiff turns joint 2 by 3°) also moves what the classical
    model predicts there: that part is the classical model's, and is taken out with its compliances fitted to ``none``
    (``(X_none - X_planted) β_none``).  Without it the difference of the two campaigns' deflections is mostly the pose's
    change, which the classical model at the planted campaign's poses already fits.
    """
    if not (np.array_equal(planted.config, none.config) and np.array_equal(planted.marker, none.marker)):
        raise ValueError("the two campaigns' rows differ: expected the same plan, repeats and markers")
    weight = np.repeat(1.0 / none.noise, 3)
    design = none.design.reshape(3 * len(none), -1)
    beta = np.linalg.lstsq(design * weight[:, np.newaxis], none.y.reshape(-1) * weight, rcond=None)[0]
    return planted.y - none.y + (none.design - planted.design) @ beta


def _whitened(share: np.ndarray, rows, cell) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``share`` (3N,) less its least-squares fit by the classical model's columns, those columns (3N, p), both in the
    cell's tracker noise of each deflection, and that noise (3N,) m."""
    sd = np.repeat(np.sqrt(cell.tracker.deflection_variance(rows.position, rows.position + rows.y)), 3)
    design = rows.design.reshape(3 * len(rows), -1) / sd[:, np.newaxis]
    whitened = share.reshape(-1) / sd
    return whitened - design @ np.linalg.lstsq(design, whitened, rcond=None)[0], design, sd


def _captured(left: np.ndarray, base: np.ndarray, sd: np.ndarray, rows, cell, extension) -> float:
    """The largest fraction, over ``extension``'s variants, of the planted share beyond the classical model (``left``,
    whitened) that the extension's columns take up on top of that model (``base``, whitened by ``sd``): what the right
    family's form can see of it."""
    best = 0.0
    for variant in extension.variants():
        added = variant.regressors(rows, cell).reshape(3 * len(rows), -1) / sd[:, np.newaxis]
        design = np.column_stack([base, added])
        fitted = design @ np.linalg.lstsq(design, left, rcond=None)[0]
        best = max(best, float(fitted @ fitted) / float(left @ left))
    return best


def _one(case: tuple, rng: np.random.Generator, cell, plan: str) -> dict:
    """One seed's planted and unplanted campaigns, written and read as the critique reads them, and the oracle judged."""
    from bayescal.cell.campaign import read_campaign
    from bayescal.critique.compare import compare, cross_validate
    from bayescal.critique.covariates import campaign_rows
    from bayescal.critique.extensions import CATALOGUE
    from bayescal.critique.rule import passes
    from bayescal_studies.studies.critique_rates import GENERATORS, weighed_cell

    name, effect, multiple, seed = case
    generator = GENERATORS[name]
    weighed = weighed_cell(cell, generator, effect)
    rows = {}
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the plan's warnings, the same for every campaign
        for which, (planted, times) in {"planted": (effect, multiple), "none": ("none", 0.0)}.items():
            (Path(folder) / which).mkdir()
            path = generator.write(planted, times, seed, False, Path(folder) / which, cell, plan)[0]
            rows[which] = campaign_rows(weighed, read_campaign(path, cell=weighed))
    planted = rows["planted"]
    share = planted_share(planted, rows["none"])
    y, design = planted.y.reshape(-1), planted.design.reshape(3 * len(planted), -1)
    scale, group, config = np.repeat(planted.noise, 3), np.tile(np.arange(3), len(planted)), np.repeat(planted.config, 3)
    gain = compare(cross_validate(y, design, scale, group, config),
                   cross_validate(y, np.column_stack([design, share.reshape(-1)]), scale, group, config))
    left, base, sd = _whitened(share, planted, weighed)
    family = CATALOGUE.get(generator.expected[effect])
    # a heavy tail has no columns, and the drift's column is fitted to the campaign's readings in time, not to the rows
    formed = family is not None and not family.robust and family.name != "drift"
    return {"generator": name, "effect": effect, "multiple": multiple, "seed": seed,
            "share_rms_um": float(np.sqrt(np.mean(share**2)) * 1e6), "noncentrality": float(left @ left),
            "captured": _captured(left, base, sd, planted, weighed, family) if formed else np.nan,
            "delta_elpd": gain.delta_elpd, "se": gain.se, "named": passes(gain)}


def detection_ceiling(
    config: str | PathLike[str],
    plan: str | PathLike[str],
    generator: str,
    effects: Sequence[str],
    *,
    multiples: Sequence[float] = (1.0,),
    seeds: Sequence[int] = range(10),
    executor: Executor | None = None,
) -> pd.DataFrame:
    """The oracle candidate (the planted effect's own shape, one free amplitude) judged at the first step, one row per campaign.

    Parameters
    ----------
    config, plan, generator, multiples, seeds, executor
        As :func:`~bayescal_studies.studies.critique_rates.critique_rates`: the same seeds give the same campaigns.
    effects
        The generator's effects; ``"none"`` has no share and is refused.

    Returns
    -------
    pandas.DataFrame
        ``generator, effect, multiple, seed, share_rms_um`` (the planted share's rms over the deflections' coordinates,
        μm), ``noncentrality`` (λ, its χ² beyond the classical model in the cell's tracker noise), ``captured`` (the
        largest fraction of λ that a variant of the right family's columns takes up on top of the classical model; NaN
        for a family without columns of the rows: a heavy tail, the drift, ``unexplained``), ``delta_elpd, se``
        (the oracle's held-out gain over the classical model, nats) and ``named`` (the naming rule passes it).
    """
    from bayescal.cell.config import load_cell
    from bayescal.design.parallel import seeded_map
    from bayescal_studies.studies.critique_rates import check_case

    check_case(generator, effects)
    if "none" in effects:
        raise ValueError(f"no planted share for effect none of generator {generator!r}")
    tasks = [(generator, e, float(m), int(s)) for e in effects for m in multiples for s in seeds]
    streams = [np.random.SeedSequence(task[-1]) for task in tasks]
    return pd.DataFrame.from_records(seeded_map(_one, tasks, streams, executor=executor, cell=load_cell(config), plan=str(plan)))


def ceiling_rates(table: pd.DataFrame) -> pd.DataFrame:
    """Per generator, effect and multiple: campaigns, the oracle named (fraction and binomial SE), the median planted
    share (μm), λ and fraction captured by the right family, and the fraction of campaigns with λ above
    :data:`~bayescal.critique.rule.SEPARABLE_CHI2`."""
    from bayescal.critique.rule import SEPARABLE_CHI2

    rows = []
    for key, group in table.groupby(["generator", "effect", "multiple"], sort=False):
        n, named = len(group), float(group["named"].mean())
        rows.append(dict(zip(("generator", "effect", "multiple"), key)) | {
            "n": n, "named": named, "named_se": float(np.sqrt(named * (1 - named) / n)),
            "share_rms_um": float(group["share_rms_um"].median()), "noncentrality": float(group["noncentrality"].median()),
            "captured": float(group["captured"].median()),
            "separable": float(np.mean(group["noncentrality"] > SEPARABLE_CHI2))})
    return pd.DataFrame.from_records(rows)
