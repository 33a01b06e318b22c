"""Closed-form least-squares estimates of eqs 33-35: the starts of every posterior.

Eq 33 solves the per-angle linear model (one joint-2 compliance per q2 angle);
eq 34 regresses the per-angle joint-2 stiffnesses on the compensator's eq-35
regressor to separate ``K_θ2^0``, ``K_c`` and ``s0·K_c``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.identifiability import Identifiability
from bayescal.robot.compensator import CompensatorGeometry

__all__ = ["ClosedForm", "closed_form", "check_regression"]


@dataclass(frozen=True)
class ClosedForm:
    """Least-squares estimates of eqs 33-35 (SI).

    Attributes
    ----------
    per_angle : numpy.ndarray
        Compliances of the identifiable per-angle columns (eq 33).
    columns : list
        ``(joint, angle)`` of each entry of ``per_angle`` (angle None for a joint other than 2).
    cov : numpy.ndarray
        Their covariance ``sigma^2 (X'X)^-1`` (eq 37) with the pooled residual variance.
    sigma : numpy.ndarray
        Residual standard deviation per noise group (m).
    compliances : numpy.ndarray
        ``(nq,)`` joint compliances with ``k2 = 1/K_theta2^0``; ``nan`` where not identifiable.
    spring : numpy.ndarray | None
        ``[K_theta2^0, K_c, s0]`` from eq 34 (None when not identifiable).
    k2 : numpy.ndarray
        Equivalent joint-2 compliance at each q2 angle (``nan`` where not identifiable).
    k2_sd : numpy.ndarray
        Its standard deviation from ``cov``.
    """

    per_angle: np.ndarray
    columns: list[tuple[int, int | None]]
    cov: np.ndarray
    sigma: np.ndarray
    compliances: np.ndarray
    spring: np.ndarray | None
    k2: np.ndarray
    k2_sd: np.ndarray


def closed_form(
    equations: DeflectionEquations,
    identifiability: Identifiability,
    geometry: np.ndarray | None,
) -> ClosedForm:
    """Eq 33 on the identifiable per-angle columns, then eq 34 for the compensator (unweighted, as the paper).

    ``geometry`` ``[L, a_x, a_y, phi]`` (m, rad) of the compensator; None without one.
    """
    X = equations.per_angle_design(identifiability.identifiable)
    k, *_ = np.linalg.lstsq(X, equations.y, rcond=None)
    residual = equations.y - X @ k
    dof = max(equations.n - X.shape[1], 1)
    cov = residual @ residual / dof * np.linalg.inv(X.T @ X)
    groups = len(equations.group_names)
    ssr = np.bincount(equations.group, weights=residual**2, minlength=groups)
    counts = np.bincount(equations.group, minlength=groups)
    sigma = np.sqrt(ssr / np.maximum(counts * dof / equations.n, 1.0))
    columns = [c for c, keep in zip(equations.per_angle_columns(), identifiability.identifiable) if keep]
    compliances = np.full(equations.n_joints, np.nan)
    k2 = np.full(equations.compensated_angles.size, np.nan)
    k2_sd = np.full(equations.compensated_angles.size, np.nan)
    for index, (value, (joint, angle)) in enumerate(zip(k, columns)):
        if angle is None:
            compliances[joint] = value
        else:
            k2[angle] = value
            k2_sd[angle] = np.sqrt(cov[index, index])
    spring = None
    if identifiability.compensator:
        known = np.isfinite(k2) & (k2 > 0)
        C = CompensatorGeometry(*geometry).regressor(equations.compensated_angles[known])
        w = np.linalg.lstsq(C, 1.0 / k2[known], rcond=None)[0]
        spring = np.array([w[0], w[1], w[2] / w[1] if w[1] != 0 else np.nan])
        compliances[equations.joint] = 1.0 / w[0]
    return ClosedForm(per_angle=k, columns=columns, cov=cov, sigma=sigma, compliances=compliances, spring=spring, k2=k2, k2_sd=k2_sd)



def check_regression(
    ident: Identifiability, columns: list[tuple[int, int | None]], q2: np.ndarray, geometry: np.ndarray
) -> Identifiability:
    """Demote the compensator when the eq 34 regressor of the identified angles is rank deficient."""
    angles = sorted({a for (_, a), keep in zip(columns, ident.identifiable) if keep and a is not None})
    C = CompensatorGeometry(*geometry).regressor(q2[angles])
    C = C / np.linalg.norm(C, axis=0)
    singular = np.linalg.svd(C, compute_uv=False)
    if singular[-1] > 1e-8 * singular[0]:
        return ident
    reason = "the eq 34 regressor of the campaign's q2 angles is rank deficient: K_c and s0*K_c cannot be separated"
    joint = next(j for j, angle in columns if angle is not None)
    reasons = dict(ident.reasons) | {name: reason for name in (f"k{joint + 1}", "K_c", "s0")}
    return replace(ident, reasons=reasons, compensator=False)


