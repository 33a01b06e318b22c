"""How much the exact model's estimates depend on what it assumes: the link masses and the nominal spring.

The exact model corrects the linear one with the arm's weight (the URDF's
link masses, themselves an estimate) and the compensator torque that balances
it (the config's spring, since the deflections determine ``K_c`` too loosely).
:func:`assumption_sensitivity` changes each assumption and reports how far the
closed-form estimates move, in posterior standard deviations.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import scale_masses
from bayescal.inference.parameters import ParameterRegistry

__all__ = ["ASSUMPTION_FACTORS", "assumption_sensitivity"]

ASSUMPTION_FACTORS = (0.8, 1.2)
"""Factors applied to the link masses and to the nominal K_c: ±20 %, a plausible error of a URDF's masses."""


def _closed_form(model: ElastostaticModel, campaign: Campaign) -> dict[str, float]:
    """The closed-form estimates in the paper's units (μrad/(N·m), N/mm, mm)."""
    estimate, _ = model.estimate(campaign)
    registry = ParameterRegistry(len(estimate.compliances), compensated_joint=model.compensated_joint)
    return registry.edge_values(estimate.compliances, None if estimate.spring is None else estimate.spring[1:])


def assumption_sensitivity(model: ElastostaticModel, campaign: Campaign, posterior: pd.DataFrame) -> pd.DataFrame:
    """Change of the closed-form estimates when the link masses or the nominal spring are changed.

    Parameters
    ----------
    model
        The exact model the campaign was identified with.
    campaign
        The campaign.
    posterior
        Indexed by parameter, columns ``mean`` and ``sd`` (paper's units): the
        parameters to report and the scale of their change.

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, one column per changed assumption (``link masses
        ×0.8`` …, ``nominal K_c ×1.2``): the change of the estimate, in
        posterior sd.  A parameter the closed form does not estimate is left out.
    """
    spring = model.nominal_spring
    changes = {}
    for factor in ASSUMPTION_FACTORS:
        changes[f"link masses ×{factor:g}"] = dataclasses.replace(model, robot=scale_masses(model.robot, factor))
    for factor in ASSUMPTION_FACTORS:
        changes[f"nominal K_c ×{factor:g}"] = dataclasses.replace(model, nominal_spring=(factor * spring[0], spring[1]))
    with warnings.catch_warnings():
        # The campaign's warnings are those of the fit the posterior came from.
        warnings.simplefilter("ignore")
        base = _closed_form(model, campaign)
        shifted = {label: _closed_form(changed, campaign) for label, changed in changes.items()}
    mean, sd = posterior["mean"], posterior["sd"]
    names = [name for name in posterior.index if np.isfinite(base.get(name, np.nan))]
    frame = pd.DataFrame(
        {label: [(values[name] - mean[name]) / sd[name] - (base[name] - mean[name]) / sd[name] for name in names] for label, values in shifted.items()},
        index=pd.Index(names, name="parameter"),
    )
    return frame
