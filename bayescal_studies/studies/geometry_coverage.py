"""Whether the geometry posterior's intervals cover: frequentist coverage on simulated campaigns.

:func:`coverage_study` simulates campaigns shaped like Table I from a known
marker layout, samples the posterior of each, and counts how often its
mean ± k sd intervals hold the truth, beside the intervals' posterior content.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import pandas as pd

from bayescal.geometry.arcs import MarkerLayout
from bayescal.geometry.posterior import GeometryPosteriorModel
from bayescal.sampling.summary import ConvergenceWarning
from bayescal.twin.arcs import simulate_markers
from bayescal.units import DEG, MM

__all__ = ["binomial_se", "coverage_study", "layout_truth"]


def layout_truth(layout: MarkerLayout) -> dict[str, float]:
    """The posterior's parameters of ``layout`` in the paper's units (mm, deg), in the frame of the fit."""
    flip = 1.0 if layout.sense < 0 else -1.0
    a = layout.p2 - layout.p0
    return {
        "L": layout.L / MM,
        "a_x": a[0] / MM,
        "a_y": flip * a[1] / MM,
        "phi": flip * layout.phi / DEG,
        "p2_x": layout.p2[0] / MM,
        "p2_y": layout.p2[1] / MM,
        "p0_x": layout.p0[0] / MM,
        "p0_y": layout.p0[1] / MM,
    }


def coverage_study(
    layout: MarkerLayout,
    q2: Sequence[float],
    sigma: float,
    n_rep: int,
    model: GeometryPosteriorModel,
    rng: np.random.Generator,
) -> pd.DataFrame:
    """Frequentist coverage of the posterior intervals mean ± k sd (k = 1, 2, 3) on simulated campaigns.

    Each replication simulates all markers at the angles ``q2`` with noise
    ``sigma`` (m), samples the posterior with ``model`` and checks whether
    each interval holds the truth.  The interval's posterior content (its
    probability under the posterior, from the draws) is averaged alongside:
    a calibrated posterior covers at that rate (under a Gaussian posterior
    it is 68.3 %, 95.4 % and 99.7 %).

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter (``L, a_x, a_y, phi, p2_x, p2_y, p0_x, p0_y``),
        columns ``covered_k`` (fraction of replications whose interval held
        the truth) and ``content_k`` (mean posterior content) for k = 1, 2, 3,
        and ``n_rep``.
    """
    truth = layout_truth(layout)
    hits = {name: np.zeros(3) for name in truth}
    content = {name: np.zeros(3) for name in truth}
    k = np.arange(1, 4)
    for _ in range(n_rep):
        points = simulate_markers(layout, q2, rng, sigma=sigma)
        with warnings.catch_warnings():
            # The study runs deliberately short chains: its coverage is the test of them.
            warnings.simplefilter("ignore", ConvergenceWarning)
            draws = model.fit(points, rng=rng).tree["posterior"]
        for name, value in truth.items():
            x = draws[name].values.ravel()
            mean, sd = x.mean(), x.std(ddof=1)
            hits[name] += np.abs(value - mean) <= k * sd
            content[name] += np.mean(np.abs(x[:, None] - mean) <= k * sd, axis=0)
    rows = {
        name: {**{f"covered_{j}": hits[name][j - 1] / n_rep for j in k}, **{f"content_{j}": content[name][j - 1] / n_rep for j in k}}
        for name in truth
    }
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame["n_rep"] = n_rep
    frame.index.name = "parameter"
    return frame


def binomial_se(rate: float, n_rep: int) -> float:
    """Standard error of a coverage rate ``rate`` estimated from ``n_rep`` independent campaigns."""
    return float(np.sqrt(rate * (1.0 - rate) / n_rep))
