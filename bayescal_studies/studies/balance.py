"""How the gravity compensator balances the arm's weight about joint 2.

Both studies put the forearm horizontal (``q3 = -q2``, other joints at zero),
where the arm's weight loads joint 2 most for a given ``q2``.
:func:`gravity_balance` tabulates the joint-2 torques of the cell's own spring
(eq 7) against the weight, with the spring's share of the joint-2 stiffness
(eq 8); :func:`spring_balance` asks how well springs stiffer than the cell's,
each with its best free length, could balance the same weight.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.units import DEG, MM

__all__ = ["BALANCE_Q2_DEG", "gravity_balance", "spring_balance"]

BALANCE_Q2_DEG = np.linspace(-140.0, 0.0, 57)
"""Joint-2 angles (deg) over which :func:`spring_balance` fits a free length: the arm's working range in 2.5° steps."""


def _forearm_horizontal(cell: Cell, q2: np.ndarray) -> np.ndarray:
    """``(n, nq)`` configurations at the joint-2 angles ``q2`` (rad) with the forearm horizontal."""
    q = np.zeros((len(q2), cell.robot.nq))
    q[:, cell.compensated_joint] = q2
    q[:, cell.compensated_joint + 1] = -q2
    return q


def _weight_torque(cell: Cell, q2: np.ndarray) -> np.ndarray:
    """Joint-2 torque (N·m) the drive supplies against the links' weight alone, at each angle of ``q2`` (rad)."""
    return np.array([cell.robot.gravity_torque(q)[cell.compensated_joint] for q in _forearm_horizontal(cell, q2)])


def gravity_balance(cell: Cell, q2_deg: Sequence[float]) -> pd.DataFrame:
    """Joint-2 torques of the arm's weight and of the cell's compensator, forearm horizontal.

    Parameters
    ----------
    cell
        A cell with a compensator.
    q2_deg
        Joint-2 angles in degrees.

    Returns
    -------
    pandas.DataFrame
        Indexed by ``q2_deg``, columns ``weight_torque_Nm`` (g2: what the drive
        would supply without the compensator), ``compensator_torque_Nm``
        (``-M_c``, eq 7), ``residual_torque_Nm`` (left to the drive),
        ``spring_length_mm`` (``s``) and ``compensator_share_pct``
        (``K_c·a·L·η / K_θ2^0``, eq 8).
    """
    compensator = cell.compensator
    q2 = np.asarray(q2_deg, dtype=float) * DEG
    weight = _weight_torque(cell, q2)
    spring = -compensator.torque(q2)
    return pd.DataFrame(
        {
            "weight_torque_Nm": weight,
            "compensator_torque_Nm": spring,
            "residual_torque_Nm": weight - spring,
            "spring_length_mm": compensator.s(q2) / MM,
            "compensator_share_pct": 100 * compensator.stiffness(q2) * cell.compliances[cell.compensated_joint],
        },
        index=pd.Index(np.asarray(q2_deg, dtype=float), name="q2_deg"),
    )


def spring_balance(cell: Cell, factors: Sequence[float], q2_deg: Sequence[float] = BALANCE_Q2_DEG) -> pd.DataFrame:
    """How well a spring ``factor`` times as stiff as the cell's, with its best free length, balances the arm's weight.

    For each factor the free length ``s0`` minimises the rms of the joint-2
    torque left to the drive over ``q2_deg``: ``M_c = K_c·a·L·sin γ·(1 - s0/s)``
    (eq 7) is linear in ``s0``, so the fit is a one-column least squares.

    Returns
    -------
    pandas.DataFrame
        Indexed by ``factor``, columns ``free_length_mm`` (the best ``s0``),
        ``residual_rms_Nm`` (rms torque left to the drive with it) and
        ``weight_max_Nm`` (the largest joint-2 torque of the weight alone).
    """
    if min(factors) <= 0:
        raise ValueError(f"spring factors must be positive, got {min(factors)}")
    compensator = cell.compensator
    q2 = np.asarray(q2_deg, dtype=float) * DEG
    weight = _weight_torque(cell, q2)
    lever = compensator.a * compensator.L * np.sin(compensator.gamma(q2))
    rows = {}
    for factor in factors:
        stiffness = factor * compensator.K_c
        # M_c must cancel the drive torque g2, and it is linear in s0.
        column = -stiffness * lever / compensator.s(q2)
        target = -weight - stiffness * lever
        s0 = float(column @ target / (column @ column))
        residual = target - column * s0
        rows[float(factor)] = (s0 / MM, float(np.sqrt(np.mean(residual**2))), float(np.abs(weight).max()))
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=["free_length_mm", "residual_rms_Nm", "weight_max_Nm"])
    frame.index.name = "factor"
    return frame
