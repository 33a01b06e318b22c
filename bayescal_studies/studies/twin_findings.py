"""What the digital twin's report says, computed once: its noise, the compensator's balance, eq-37
precision against Table IV and the effects it can plant.

:func:`twin_findings` simulates one campaign of a plan and runs
:func:`~bayescal_studies.studies.balance.gravity_balance`,
:func:`~bayescal_studies.studies.precision.design_precision` and
:func:`~bayescal_studies.studies.precision.effect_detectability` for every planted effect at
its default magnitude; :mod:`bayescal_studies.reports.twin` only words the :class:`TwinFindings`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal_studies.studies.balance import gravity_balance
from bayescal_studies.studies.precision import design_precision, effect_detectability, table_iv_width_ratio
from bayescal.twin.effects import EFFECTS
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import MM, UM

__all__ = ["BALANCE_TABLE_Q2_DEG", "EffectFinding", "TwinFindings", "twin_findings"]

BALANCE_TABLE_Q2_DEG = (0.0, -25.24, -56.9, -90.0, -99.85, -120.0, -140.0)
"""Joint-2 angles of the balance table: Table III's q2 angles with the range's ends and middle."""


@dataclass(frozen=True)
class EffectFinding:
    """One planted effect at one magnitude against the linearised identification model.

    Attributes
    ----------
    label
        ``name=magnitude unit``, or what the row compares when no effect is planted.
    detectability
        :func:`~bayescal_studies.studies.precision.effect_detectability` of the effect.
    detectable
        Its noncentrality reaches the χ² spread sqrt(2n) of the campaign.
    """

    label: str
    detectability: dict
    detectable: bool


@dataclass(frozen=True)
class TwinFindings:
    """Every number and verdict of the twin's report; see :func:`twin_findings`.

    Attributes
    ----------
    n_configurations, repeats, n_markers, n_equations
        The campaign's size.
    sigma_range_um
        Smallest and largest tracker noise per coordinate of the campaign (μm).
    deflection_range_mm
        Smallest and largest marker deflection under the load (mm).
    tracker
        ``factor``, ``U0_um``, ``U1_um_per_m`` of the cell's tracker.
    balance
        :func:`~bayescal_studies.studies.balance.gravity_balance` at :data:`BALANCE_TABLE_Q2_DEG`, or ``None`` without a compensator.
    precision
        :func:`~bayescal_studies.studies.precision.design_precision` of the plan.
    width_ratio
        The parameters and the geometric mean of their width ratios twin/Table IV.
    chi2_spread
        sqrt(2n), the χ² spread the effects' noncentrality is compared with.
    effects
        The twin against the linear model, then each planted effect at its default magnitude.
    """

    n_configurations: int
    repeats: int
    n_markers: int
    n_equations: int
    seed: int
    sigma_range_um: tuple[float, float]
    deflection_range_mm: tuple[float, float]
    tracker: dict[str, float]
    balance: pd.DataFrame | None
    precision: pd.DataFrame
    width_ratio: tuple[list[str], float]
    chi2_spread: float
    effects: tuple[EffectFinding, ...]


def twin_findings(cell: Cell, plan: Plan, *, repeats: int = 3, seed: int = 1) -> TwinFindings:
    """The twin's campaign of ``plan`` with ``seed``, its precision and the detectability of its effects."""
    campaign = DigitalTwin(cell).simulate(plan, repeats, np.random.default_rng(seed))
    deflection = np.linalg.norm(campaign.displacement, axis=1) / MM
    precision = design_precision(cell, plan, repeats)
    n = campaign.n_equations
    threshold = math.sqrt(2 * n)
    balance = gravity_balance(cell, BALANCE_TABLE_Q2_DEG) if cell.compensator is not None else None

    def finding(label: str, result: dict) -> EffectFinding:
        return EffectFinding(label, result, bool(result["noncentrality"] >= threshold))

    effects = [finding("none (twin vs linear model)", effect_detectability(cell, plan, None, repeats=repeats))]
    for name, cls in EFFECTS.items():
        if name == "compensator" and cell.compensator is None:
            continue
        magnitude = 0.0 if name == "compensator" else cls.default
        effects.append(finding(f"{name}={magnitude:g} {cls.unit}", effect_detectability(cell, plan, cls(magnitude), repeats=repeats)))
    return TwinFindings(
        n_configurations=len(plan),
        repeats=repeats,
        n_markers=len(cell.markers),
        n_equations=n,
        seed=seed,
        sigma_range_um=tuple(sd / UM for sd in cell.tracker.sigma_range(campaign.p0, campaign.p1)),
        deflection_range_mm=(float(deflection.min()), float(deflection.max())),
        tracker={"factor": cell.tracker.factor, "U0_um": cell.tracker.U0 / UM, "U1_um_per_m": cell.tracker.U1 / UM},
        balance=balance,
        precision=precision,
        width_ratio=table_iv_width_ratio(precision),
        chi2_spread=threshold,
        effects=tuple(effects),
    )
