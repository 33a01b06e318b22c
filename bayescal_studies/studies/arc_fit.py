"""How precisely the lever arc is fitted: the known-angle fit against circle fits and the Cramér-Rao bounds.

:func:`arc_fit_study` simulates the lever marker P1 at known joint angles and
compares the root mean square errors of the known-angle fit (eqs 10-19) with
those of three circle fits that ignore the angles, and with the Cramér-Rao
bounds with and without the angles.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from bayescal.geometry.arcs import LEVER_MARKER, MarkerLayout, known_angle_fit
from bayescal.geometry.circle import geometric_fit, hyper_fit, kasa_fit, known_angle_crb, unknown_angle_crb
from bayescal.twin.arcs import TABLE_I_NOISE
from bayescal.units import MM

__all__ = ["TABLE_I_NOISE", "arc_fit_study"]

# The noise of campaigns simulated like Table I is the geometry twin's (bayescal.twin.arcs).


def arc_fit_study(layout: MarkerLayout, q2: Sequence[float], sigma: float, n_rep: int, rng: np.random.Generator) -> pd.DataFrame:
    """Monte-Carlo errors of the lever-arc fits on simulated P1 points.

    Parameters
    ----------
    layout
        The true marker layout (only P1 is used).
    q2
        Joint angles in rad.
    sigma
        Noise sd per coordinate in m.
    n_rep
        Number of simulated arcs.
    rng
        Random generator.

    Returns
    -------
    pandas.DataFrame
        Indexed by method (``known-angle``, ``geometric``, ``hyper``, ``kasa``,
        ``CRB known angles``, ``CRB unknown angles``), columns ``rmse_L_mm``
        and ``rmse_centre_mm`` (root mean square Euclidean error of the
        centre); the CRB rows hold the bounds' square roots.
    """
    q2 = np.asarray(q2, dtype=float)
    exact = layout.positions(q2)[LEVER_MARKER]
    fits = {"known-angle": [], "geometric": [], "hyper": [], "kasa": []}
    for _ in range(n_rep):
        noisy = exact + sigma * rng.standard_normal(exact.shape)
        hyper = hyper_fit(noisy)
        for method, fit in (
            ("known-angle", known_angle_fit(q2, noisy)),
            ("geometric", geometric_fit(noisy, start=hyper)),
            ("hyper", hyper),
            ("kasa", kasa_fit(noisy)),
        ):
            fits[method].append((fit.radius, *fit.centre))
    rows = {}
    for method, values in fits.items():
        values = np.array(values)
        rows[method] = (
            np.sqrt(np.mean((values[:, 0] - layout.L) ** 2)),
            np.sqrt(np.mean(np.sum((values[:, 1:] - layout.p2) ** 2, axis=1))),
        )
    known_bound = known_angle_crb(q2, layout.L, layout.phi, sigma, layout.sense)
    unknown_bound = unknown_angle_crb(layout.phi + layout.sense * q2, sigma)
    rows["CRB known angles"] = (np.sqrt(known_bound[2, 2]), np.sqrt(known_bound[0, 0] + known_bound[1, 1]))
    rows["CRB unknown angles"] = (np.sqrt(unknown_bound[2, 2]), np.sqrt(unknown_bound[0, 0] + unknown_bound[1, 1]))
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=["rmse_L_mm", "rmse_centre_mm"]) / MM
    frame.index.name = "method"
    return frame
