"""Closed-form least-squares estimates of eqs 33-35: the starts of every posterior.

Eq 33 solves the per-angle linear model (one joint-2 compliance per q2 angle);
eq 34 regresses the per-angle joint-2 stiffnesses on the compensator law's
regressor (eq 35 for the spring) to separate ``K_θ2^0`` and the law's linear
parameters (``K_c`` and ``s0·K_c``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.identifiability import Identifiability
from bayescal.robot.compensator import law_on
from bayescal.robot.laws import CompensatorLaw

__all__ = ["ClosedForm", "closed_form", "check_regression", "MAX_REGRESSIONS"]

MAX_REGRESSIONS = 20
"""Regressions of eq 34 at most for a law whose regressor depends on its parameters: each at the last one's."""


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
        ``[K_theta2^0, *law values]`` from eq 34 (``[K_theta2^0, K_c, s0]`` for the spring; None when not identifiable).
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
    law: CompensatorLaw | None = None,
) -> ClosedForm:
    """Eq 33 on the identifiable per-angle columns, then eq 34 for the compensator (unweighted, as the paper).

    ``geometry`` ``[L, a_x, a_y, phi]`` (m, rad) of the compensator; None without one.  ``law`` is its law at the
    values a regressor that depends on them starts at (None: the spring of eqs 4-9).
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
        spring = regress(law_on(law, geometry), equations.compensated_angles[known], 1.0 / k2[known])
        compliances[equations.joint] = 1.0 / spring[0]
    return ClosedForm(per_angle=k, columns=columns, cov=cov, sigma=sigma, compliances=compliances, spring=spring, k2=k2, k2_sd=k2_sd)

def regress(law: CompensatorLaw, q: np.ndarray, stiffness: np.ndarray) -> np.ndarray:
    """``[K_θ^0, *values]`` (SI) of eq 34: the joint's ``stiffness`` (N·m/rad) at angles ``q`` (rad) regressed on
    ``law``'s rows, again at the values found while they move (:data:`MAX_REGRESSIONS`)."""
    for _ in range(MAX_REGRESSIONS):
        w = np.linalg.lstsq(law.regressor(q), stiffness, rcond=None)[0]
        values = law.from_linear(w[1:])
        if law.EXACT_REGRESSOR or not np.all(np.isfinite(values)) or np.allclose(values, law.values, rtol=1e-10, atol=0.0):
            break
        try:
            law = law.at(law.vector, values)
        except ValueError:
            # Values outside the law's domain (a negative force, say): the posterior's start handles them.
            break
    return np.concatenate([w[:1], values])


def check_regression(
    ident: Identifiability, columns: list[tuple[int, int | None]], q2: np.ndarray, geometry: np.ndarray, law: CompensatorLaw | None = None
) -> Identifiability:
    """Demote the compensator when the eq 34 regressor of the identified angles is rank deficient."""
    angles = sorted({a for (_, a), keep in zip(columns, ident.identifiable) if keep and a is not None})
    law = law_on(law, geometry)
    C = law.regressor(q2[angles])
    C = C / np.linalg.norm(C, axis=0)
    singular = np.linalg.svd(C, compute_uv=False)
    if singular[-1] > 1e-8 * singular[0]:
        return ident
    reason = f"the eq 34 regressor of the campaign's q2 angles is rank deficient: {' and '.join(law.LINEAR)} cannot be separated"
    joint = next(j for j, angle in columns if angle is not None)
    reasons = dict(ident.reasons) | {name: reason for name in (f"k{joint + 1}", *(p.name for p in law.PARAMETERS))}
    return replace(ident, reasons=reasons, compensator=False)


