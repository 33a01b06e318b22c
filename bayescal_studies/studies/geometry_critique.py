"""How the geometry critique fares on simulated tracker arcs: planted effects and false alarms.

:func:`geometry_detection` runs :class:`~bayescal.critique.geometry.GeometryCritique`
on campaigns of the geometry's twin (:func:`bayescal.twin.arcs.simulate_markers`,
one effect planted in its own physical terms, never told to the critique) and
tabulates how often the planted effect is named first.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.geometry.arcs import MarkerLayout
from bayescal_studies.studies.arc_fit import TABLE_I_NOISE
from bayescal.design.parallel import seeded_map
from bayescal.twin.arcs import PLANTED, SPRING_K, SPRING_S0, TILT_AXIS, simulate_markers

__all__ = ["PLANTED", "SPRING_K", "SPRING_S0", "TILT_AXIS", "simulate_markers", "geometry_detection"]


def _one(case: tuple[str | None, float | None], rng: np.random.Generator, *, layout: MarkerLayout, q2: np.ndarray, sigma: float) -> list[str]:
    """The causes the geometry critique names in one simulated campaign (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
    from bayescal.critique.geometry import GeometryCritique

    effect, magnitude = case
    points = simulate_markers(layout, q2, rng, effect, magnitude, sigma)
    return GeometryCritique().run(points).causes


def geometry_detection(
    layout: MarkerLayout,
    q2: Sequence[float],
    magnitudes: Mapping[str, Sequence[float]],
    *,
    n_seeds: int = 20,
    n_null: int = 40,
    sigma: float = TABLE_I_NOISE,
    seed: int = 0,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """How often each planted effect is named first, and how often points without an effect are called a misfit.

    Parameters
    ----------
    layout, q2, sigma
        The true layout, the joint angles (rad) and the noise (m) of every simulated campaign.
    magnitudes
        Effect name to the magnitudes to plant (units of :data:`PLANTED`).
    n_seeds, n_null
        Campaigns per effect and magnitude, and without any effect.
    seed
        Root seed; every campaign's seed is spawned from it, so the table does not depend on the executor.
    executor
        Runs the campaigns (:func:`~bayescal.design.parallel.seeded_map`; default a process pool).

    Returns
    -------
    pandas.DataFrame
        One row per effect and magnitude (``none`` first): ``effect, magnitude, unit, campaigns,
        first_cause`` (fraction naming the planted effect first), ``named`` (at any step), ``misfit`` (any
        cause) and ``unexplained`` (a misfit no extension explains).
    """
    cases = [("none", None, n_null)] + [(effect, m, n_seeds) for effect, values in magnitudes.items() for m in values]
    seeds = np.random.SeedSequence(seed).generate_state(max(n_seeds, n_null))
    q2 = np.asarray(q2, dtype=float)
    items = [(None if e == "none" else e, m) for e, m, n in cases for _ in range(n)]
    # Campaign k of every case draws from seed k: the same noise across effects and magnitudes.
    streams = [np.random.SeedSequence(int(s)) for _, _, n in cases for s in seeds[:n]]
    results = seeded_map(_one, items, streams, executor=executor, layout=layout, q2=q2, sigma=sigma)
    rows, start = [], 0
    for effect, magnitude, n in cases:
        causes = results[start : start + n]
        start += n
        rows.append(
            {
                "effect": effect,
                "magnitude": 0.0 if magnitude is None else magnitude,
                "unit": "" if effect == "none" else PLANTED[effect][1],
                "campaigns": n,
                "first_cause": np.mean([c[:1] == [effect] for c in causes]),
                "named": np.mean([effect in c for c in causes]),
                "misfit": np.mean([bool(c) for c in causes]),
                "unexplained": np.mean(["unexplained" in c for c in causes]),
            }
        )
    return pd.DataFrame(rows)
