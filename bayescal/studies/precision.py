"""What a plan can identify, before any campaign is measured: precision and effect detectability.

:func:`design_precision` gives the precision the linear identification model
(Klimchik et al., eqs 30-37) can reach on a plan with the cell's tracker noise,
and :func:`effect_detectability` how far a planted effect stands above the
tracker noise once the joint model has absorbed what it can.  Both return plain
tables for the reports to render.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.reference import published
from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.robot.stiffness import compliance_design
from bayescal.twin.effects import Effect
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import MM, N_PER_MM, URAD_PER_NM

__all__ = ["design_precision", "effect_detectability"]


def _linear_model_names(cell: Cell) -> list[str]:
    names = [f"k{j}" for j in range(1, cell.robot.nq + 1)]
    return names + (["K_c", "s0"] if cell.compensator is not None else [])


def _linear_model(cell: Cell, plan: Plan, repeats: int):
    """Design of the linearised identification model, its true parameters and the noise of each equation.

    The parameters are ``k1..k6`` (rad/(N·m)) with, when the cell has a compensator,
    ``k2`` read as ``K_θ2^0`` through eq 8 and ``K_c`` (N/m) and ``s0`` (m) appended.
    """
    robot, compensator, k = cell.robot, cell.compensator, cell.compliances
    names = _linear_model_names(cell)
    truth = list(k)
    if compensator is not None:
        truth += [compensator.K_c, compensator.s0]
    blocks, sigmas, predicted = [], [], []
    j2 = COMPENSATED_JOINT
    for q, mass in zip(plan.q, plan.masses(cell.load_mass)):
        wrench = cell.load_wrench(q, mass)
        effective = k.copy()
        chain = np.eye(robot.nq, len(names))
        if compensator is not None:
            effective[j2] = 1.0 / (1.0 / k[j2] + compensator.stiffness(q[j2]))
            # K_c·a·L·η = C1·K_c + C2·s0·K_c (eq 35), so its derivatives in K_c and s0 are C1 + s0·C2 and K_c·C2.
            _, c1, c2 = compensator.regressor(q[j2])
            chain[j2, j2] = effective[j2] ** 2 / k[j2] ** 2
            chain[j2, -2] = -effective[j2] ** 2 * (c1 + compensator.s0 * c2)
            chain[j2, -1] = -effective[j2] ** 2 * compensator.K_c * c2
        designs = [compliance_design(robot, q, point, wrench) for point in cell.markers.values()]
        noise = [np.sqrt(2.0) * cell.tracker.sigma(robot.point_position(q, point)) for point in cell.markers.values()]
        # the campaign's row order: repeat, then marker
        for _ in range(repeats):
            for design, sigma in zip(designs, noise):
                blocks.append(design @ chain)
                predicted.append(design @ effective)
                sigmas.append(np.full(3, sigma))
    return names, np.array(truth), np.vstack(blocks), np.concatenate(sigmas), np.concatenate(predicted)


def _identifiable(design: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Parameters whose change by their own size moves some marker (columns scaled to a common unit)."""
    scale = np.linalg.norm(design * np.abs(truth), axis=0)
    return scale > 1e-9 * scale.max()


def design_precision(cell: Cell, plan: Plan, repeats: int = 3) -> pd.DataFrame:
    """Precision of the linearised identification (eq 37) on ``plan`` with the cell's tracker noise.

    ``cov = (Bᵀ W B)⁻¹`` with ``B`` the eq-30 design in the parameters
    ``k_j`` (``k2`` without the compensator), ``K_c`` and ``s0``, and ``W`` the inverse
    variance of each deflection coordinate (two tracker readings per deflection).
    Parameters the plan cannot excite (a zero column, e.g. ``k1`` under vertical
    loads) are reported with NaN.

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, columns ``value``, ``sd``, ``width_3sd_pct`` (3 sd as a
        percentage of the value), ``table_iv_pct`` (Klimchik et al., Table IV) and
        ``unit``, values in the paper's units (μrad/(N·m), N/mm, mm).
    """
    names, truth, design, sigma, _ = _linear_model(cell, plan, repeats)
    usable = _identifiable(design, truth)
    weighted = design[:, usable] / sigma[:, np.newaxis]
    # Scaling the columns keeps the normal matrix well conditioned across N/m and rad/(N·m).
    scale = np.abs(truth[usable])
    covariance = np.linalg.inv((weighted * scale).T @ (weighted * scale)) * np.outer(scale, scale)
    sd = np.full(len(names), np.nan)
    sd[usable] = np.sqrt(np.diag(covariance))
    unit_scale = {name: 1.0 / URAD_PER_NM for name in names if name.startswith("k")} | {"K_c": 1.0 / N_PER_MM, "s0": 1.0 / MM}
    units = {name: "urad/(N m)" for name in names if name.startswith("k")} | {"K_c": "N/mm", "s0": "mm"}
    factors = np.array([unit_scale[name] for name in names])
    return pd.DataFrame(
        {
            "value": truth * factors,
            "sd": sd * factors,
            "width_3sd_pct": 300.0 * sd / np.abs(truth),
            "table_iv_pct": [_table_iv_width_percent(name) for name in names],
            "unit": [units[name] for name in names],
        },
        index=pd.Index(names, name="parameter"),
    )


def effect_detectability(cell: Cell, plan: Plan, effect: Effect | None, *, repeats: int = 3, seed: int = 0) -> dict[str, float]:
    """How far an effect's deflections stand above the tracker noise once the joint model absorbs what it can.

    The deflections ``Δp`` of a noiseless twin with the effect are compared with
    those of the noiseless twin without it (``effect=None``: the twin without
    effects against the linear model itself, at the true parameters).  The
    difference is projected out of the linearised identification model's columns
    (a refit of the joint compliances and the compensator); what is left cannot be
    explained by the joint model.

    Returns
    -------
    dict
        ``rms_difference_um`` (RMS change of the deflection coordinates),
        ``rms_unexplained_um`` (RMS left after the refit), ``noise_sd_um`` (RMS
        standard deviation of one deflection coordinate) and ``noncentrality``:
        ``Σ r²/σ²`` over all equations, the shift it causes in the χ² of the fit
        (compare with ``sqrt(2 n)`` for ``n`` equations, the χ² spread);
        ``n_equations``; ``parameter_shift_pct``: how much the refit moves each
        identifiable parameter, in % of its value (the bias the effect causes).
    """
    _, truth, design, sigma, predicted = _linear_model(cell, plan, repeats)
    silent = replace(cell, tracker=replace(cell.tracker, factor=0.0))
    rng = np.random.default_rng(seed)
    baseline = DigitalTwin(silent).simulate(plan, repeats, rng).displacement.ravel()
    if effect is None:
        changed, reference = baseline, predicted
    else:
        changed = DigitalTwin(silent, [effect]).simulate(plan, repeats, rng).displacement.ravel()
        reference = baseline
    difference = changed - reference
    usable = _identifiable(design, truth)
    weighted = design[:, usable] * np.abs(truth[usable]) / sigma[:, np.newaxis]
    target = difference / sigma
    solution, *_ = np.linalg.lstsq(weighted, target, rcond=None)
    residual = target - weighted @ solution
    names = [name for name, keep in zip(_linear_model_names(cell), usable) if keep]
    return {
        "rms_difference_um": float(np.sqrt(np.mean(difference**2)) / 1e-6),
        "rms_unexplained_um": float(np.sqrt(np.mean((residual * sigma) ** 2)) / 1e-6),
        "noise_sd_um": float(np.sqrt(np.mean(sigma**2)) / 1e-6),
        "noncentrality": float(residual @ residual),
        "n_equations": int(len(difference)),
        "parameter_shift_pct": {name: float(100.0 * value) for name, value in zip(names, solution)},
    }


def _table_iv_width_percent(name: str) -> float:
    value, half_width = published("IV").get(name, (np.nan, np.nan))
    return 100.0 * half_width / value
