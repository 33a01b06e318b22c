"""How precisely a posterior knows the compensated joint's equivalent compliance over its range (the paper's Fig. 7).

:func:`equivalent_compliance_band` evaluates every posterior draw of the
spring (and of the compensator geometry, when it was propagated) over the
joint's range and gives the 99.73 % band beside the cell's own compliance;
the review plots it and the elastostatic report quotes its width.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.inference.results import ElastostaticResults
from bayescal.units import DEG, URAD_PER_NM

__all__ = ["BAND_POINTS", "equivalent_compliance_band"]


BAND_POINTS = 60
"""Joint-2 angles at which :func:`equivalent_compliance_band` evaluates the posterior, evenly over the joint's range."""

THREE_SIGMA_TAILS = (0.00135, 0.99865)
"""Lower and upper quantiles of the posterior's 99.73 % band, the paper's ±3σ content."""


def equivalent_compliance_band(results: ElastostaticResults, cell: Cell, n_points: int = BAND_POINTS) -> pd.DataFrame:
    """The posterior's 99.73 % band of joint 2's equivalent compliance over the joint's range, beside the cell's truth.

    Every posterior draw of the spring (and of the compensator geometry, when
    it was propagated) gives ``1/(K_θ2^0 + K_c·a·L·η(q2))`` (eq 8); the band is
    its 0.135 % and 99.865 % quantiles at each angle.

    Returns
    -------
    pandas.DataFrame
        Indexed by ``q2_deg`` (``n_points`` angles over the joint's limits),
        columns ``low_urad_per_Nm``, ``median_urad_per_Nm``,
        ``high_urad_per_Nm`` (the band), ``truth_urad_per_Nm`` (the cell's
        compliance and spring) and ``half_width_pct`` (half the band in % of the median).
    """
    joint = cell.compensated_joint
    q2 = np.linspace(cell.robot.lower[joint], cell.robot.upper[joint], n_points)
    truth = 1.0 / cell.compensator.joint_stiffness(q2, 1.0 / cell.compliances[joint])
    low, median, high = np.quantile(results.equivalent_compliance(q2), [THREE_SIGMA_TAILS[0], 0.5, THREE_SIGMA_TAILS[1]], axis=0)
    return pd.DataFrame(
        {
            "low_urad_per_Nm": low / URAD_PER_NM,
            "median_urad_per_Nm": median / URAD_PER_NM,
            "high_urad_per_Nm": high / URAD_PER_NM,
            "truth_urad_per_Nm": truth / URAD_PER_NM,
            "half_width_pct": 50.0 * (high - low) / median,
        },
        index=pd.Index(q2 / DEG, name="q2_deg"),
    )
