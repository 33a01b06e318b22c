"""What a plan can identify: precision and effect detectability.

:func:`design_precision` gives the precision the linear identification model
(Klimchik et al., eqs 30-37) can reach on a plan with the cell's tracker noise,
and :func:`effect_detectability` how far a planted effect stands above the
tracker noise once the joint model has absorbed what it can.  After a fit,
:func:`compensator_precision` carries the per-angle joint-2 compliances to the
compensator's ``K_c`` and ``s0`` (eq 34) and says how much more precise they
would have to be for Table IV's widths.  All return plain tables for the
reports to render; the band of Fig. 7 is the product's
(:mod:`bayescal.inference.compliance_band`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from bayescal.design.criteria import compliance_chain, nominal_parameters, parameter_names
from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.inference.parameters import ParameterRegistry, label_angle
from bayescal.reference import width_3sd_pct
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.robot.stiffness import compliance_design
from bayescal.twin.effects import Effect
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import UM, URAD_PER_NM

if TYPE_CHECKING:
    from bayescal.inference.results import ElastostaticResults

__all__ = ["CompensatorPrecision", "compensator_precision", "design_precision", "effect_detectability", "table_iv_width_ratio"]


def _linear_model(cell: Cell, plan: Plan, repeats: int):
    """Design of the linearised identification model, its true parameters and the noise of each equation.

    The parameters are ``k1..k6`` (rad/(N·m)) with, when the cell has a compensator,
    ``k2`` read as ``K_θ2^0`` through eq 8 and ``K_c`` (N/m) and ``s0`` (m) appended.
    """
    robot = cell.robot
    names, truth = parameter_names(cell), nominal_parameters(cell)
    blocks, sigmas, predicted = [], [], []
    for q, mass in zip(plan.q, plan.masses(cell.load_mass)):
        wrench = cell.load_wrench(q, mass)
        effective, chain = compliance_chain(cell, float(q[cell.plan_joint]))
        designs = [compliance_design(robot, q, point, wrench) for point in cell.markers.values()]
        noise = [np.sqrt(2.0) * cell.tracker.sigma(robot.point_position(q, point)) for point in cell.markers.values()]
        # the campaign's row order: repeat, then marker
        for _ in range(repeats):
            for design, sigma in zip(designs, noise):
                blocks.append(design @ chain)
                predicted.append(design @ effective)
                sigmas.append(np.full(3, sigma))
    return names, truth, np.vstack(blocks), np.concatenate(sigmas), np.concatenate(predicted)


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
    parameters = [ParameterRegistry.of_cell(cell)[name] for name in names]
    factors = np.array([1.0 / p.si_factor for p in parameters])
    return pd.DataFrame(
        {
            "value": truth * factors,
            "sd": sd * factors,
            "width_3sd_pct": width_3sd_pct(truth, sd),
            # The cell's published widths (Table IV for the KR-270); NaN for a cell that names none.
            "table_iv_pct": [100.0 * p.published[1] / p.published[0] if p.published else np.nan for p in parameters],
            "unit": [p.unit for p in parameters],
        },
        index=pd.Index(names, name="parameter"),
    )


def table_iv_width_ratio(precision: pd.DataFrame) -> tuple[list[str], float]:
    """Geometric mean of the width ratios of :func:`design_precision` to Table IV over the excited joint compliances.

    Returns
    -------
    tuple
        The joint compliances compared (those the plan excites and Table IV lists)
        and the geometric mean of their ``width_3sd_pct / table_iv_pct``.
    """
    compared = [
        name
        for name, row in precision.iterrows()
        if name.startswith("k") and np.isfinite(row["width_3sd_pct"]) and np.isfinite(row["table_iv_pct"])
    ]
    ratios = precision.loc[compared, "width_3sd_pct"] / precision.loc[compared, "table_iv_pct"]
    return compared, float(np.exp(np.mean(np.log(ratios))))


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
    names = [name for name, keep in zip(parameter_names(cell), usable) if keep]
    return {
        "rms_difference_um": float(np.sqrt(np.mean(difference**2)) / UM),
        "rms_unexplained_um": float(np.sqrt(np.mean((residual * sigma) ** 2)) / UM),
        "noise_sd_um": float(np.sqrt(np.mean(sigma**2)) / UM),
        "noncentrality": float(residual @ residual),
        "n_equations": int(len(difference)),
        "parameter_shift_pct": {name: float(100.0 * value) for name, value in zip(names, solution)},
    }


@dataclass(frozen=True)
class CompensatorPrecision:
    """The precision :func:`compensator_precision` finds for the compensator spring.

    Attributes
    ----------
    per_angle
        Indexed by ``q2_deg`` (the campaign's identifiable joint-2 angles),
        columns ``compliance_urad_per_Nm`` (closed-form equivalent joint-2
        compliance), ``width_3sd_pct`` (its eq-37 ±3σ in %) and
        ``compensator_share_pct`` (``K_c·a·L·η / K_θ2^0`` of the cell's spring, eq 8).
    spring
        Indexed by parameter (``K_c``, ``s0``), columns ``width_3sd_pct``
        (±3σ carried through eq 34), ``table_iv_width_pct`` and
        ``needed_factor``: how many times more precise the per-angle
        compliances must be for Table IV's width.
    """

    per_angle: pd.DataFrame
    spring: pd.DataFrame

    @property
    def needed_per_angle_width_pct(self) -> float:
        """The median per-angle ±3σ (%) that would give both of Table IV's compensator widths."""
        return float(self.per_angle["width_3sd_pct"].median() / self.spring["needed_factor"].max())


def compensator_precision(results: ElastostaticResults, cell: Cell) -> CompensatorPrecision:
    """What the per-angle joint-2 compliances give for K_c and s0 through eq 34, and what Table IV's widths would need.

    The covariance of the per-angle compliances (eq 37, from the closed form)
    is carried to ``[K_theta2^0, K_c, s0 K_c]`` through the least squares of
    eq 34 at the cell's spring, then to ``s0``; the relative ±3σ widths are
    compared with Table IV's.  The required improvement of the per-angle
    compliances is the ratio of the widths (they scale together with the noise).
    """
    cf = results.closed_form
    ident = results.identifiability
    kept = [name for name, keep in zip(ident.names, ident.identifiable) if keep]
    joint2 = [name for name in ident.names if label_angle(name) is not None]
    index = [i for i, name in enumerate(kept) if name in joint2]
    angles = [joint2.index(kept[i]) for i in index]
    k2 = cf.per_angle[index]
    cov_k = cf.cov[np.ix_(index, index)]
    # Stiffness K = 1/k: its covariance by the delta method.
    jacobian = np.diag(-1.0 / k2**2)
    cov_K = jacobian @ cov_k @ jacobian.T
    compensator = cell.compensator
    C = CompensatorGeometry(*results.geometry.mean).regressor(results.compensated_angles[angles])
    projection = np.linalg.pinv(C)
    cov_w = projection @ cov_K @ projection.T
    Kc, s0 = compensator.K_c, compensator.s0
    w = np.array([1.0 / cell.compliances[cell.compensated_joint], Kc, s0 * Kc])
    gradient_s0 = np.array([0.0, -w[2] / w[1] ** 2, 1.0 / w[1]])
    width = {
        "K_c": width_3sd_pct(Kc, np.sqrt(cov_w[1, 1])),
        "s0": width_3sd_pct(s0, np.sqrt(gradient_s0 @ cov_w @ gradient_s0)),
    }
    registry = ParameterRegistry.of_cell(cell)
    table_iv = {name: 100.0 * registry[name].published[1] / registry[name].published[0] if registry[name].published else np.nan for name in width}
    per_angle = pd.DataFrame(
        {
            "compliance_urad_per_Nm": k2 / URAD_PER_NM,
            "width_3sd_pct": width_3sd_pct(k2, np.sqrt(np.diag(cov_k))),
            "compensator_share_pct": 100.0 * np.abs(compensator.stiffness(results.compensated_angles[angles])) * cell.compliances[cell.compensated_joint],
        },
        index=pd.Index([label_angle(joint2[a]) for a in angles], name=registry.angle_dimension),
    )
    spring = pd.DataFrame(
        {
            "width_3sd_pct": width,
            "table_iv_width_pct": table_iv,
            "needed_factor": {name: width[name] / table_iv[name] for name in width},
        }
    )
    spring.index.name = "parameter"
    return CompensatorPrecision(per_angle=per_angle, spring=spring)
