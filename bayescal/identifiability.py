"""Which elastostatic parameters a calibration campaign can determine, and how well.

The analysis works on the per-angle design of eq 30 (Klimchik et al.): one
column per joint compliance, joint 2 split by distinct q2 angle.  Columns are
scaled to unit length so that the information matrix ``X'X`` measures
collinearity rather than units; its rank, its condition number and each
parameter's variance inflation factor (the diagonal of its inverse: 1 for a
column orthogonal to the others) follow.  A parameter is not identifiable when
its column vanishes (no load in the campaign moves it) or when it has a
component in the null space of the information matrix (the data determine only
a combination of it with others).  The reason is worded from the data: the
largest torque the loads exert about the joint, or the parameters it is
confounded with.  The compensator's ``K_c`` and ``s0`` (and ``K_theta2^0``,
hence k2) need at least three q2 angles with an identifiable joint-2
compliance, the number of unknowns of eq 34.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Identifiability", "analyse", "RANK_TOLERANCE", "ILL_CONDITIONED"]

RANK_TOLERANCE = 1e-8
"""Singular values of the unit-column information matrix's square root below this fraction of the largest count as zero."""
ILL_CONDITIONED = 1e4
"""Condition number of the unit-column design above which the estimates are flagged as fragile."""
_NO_TORQUE = 1e-6
"""A joint whose largest torque is below this fraction of the largest torque on any joint is taken as unloaded."""
_MIN_ANGLES = 3


@dataclass(frozen=True)
class Identifiability:
    """Result of :func:`analyse`.

    Attributes
    ----------
    names : list of str
        Per-angle parameter names (``k1``, ``k2@<q2>deg`` …, ``k6``).
    identifiable : numpy.ndarray of bool
        For each per-angle parameter.
    rank : int
        Rank of the per-angle design.
    condition_number : float
        Of the unit-column design restricted to the identifiable parameters.
    vif : dict
        Variance inflation factor of each identifiable per-angle parameter.
    reasons : dict
        Reason, in words, for each parameter (per-angle names and ``k2``, ``K_c``,
        ``s0``) that is not identifiable.
    compensator : bool
        Whether ``K_theta2^0``, ``K_c`` and ``s0`` are identifiable.
    """

    names: list[str]
    identifiable: np.ndarray
    rank: int
    condition_number: float
    vif: dict[str, float]
    reasons: dict[str, str] = field(default_factory=dict)
    compensator: bool = True

    @property
    def ill_conditioned(self) -> bool:
        """True when the condition number exceeds :data:`ILL_CONDITIONED`."""
        return self.condition_number > ILL_CONDITIONED

    def to_json(self) -> dict:
        """The ``identifiability`` block of the CLI output."""
        return {
            "rank": self.rank,
            "n_parameters": len(self.names),
            "condition_number": self.condition_number,
            "not_identifiable": dict(self.reasons),
        }


def angle_label(q2: float) -> str:
    """Name of the joint-2 compliance at ``q2`` (rad): ``k2@-25.24deg``."""
    return f"k2@{math.degrees(q2):.2f}deg"


def analyse(
    design: np.ndarray,
    columns: Sequence[tuple[int, int | None]],
    q2: np.ndarray,
    torque: np.ndarray,
    torque_angle: np.ndarray,
) -> Identifiability:
    """Rank, conditioning and identifiability of the per-angle design.

    Parameters
    ----------
    design
        ``(n, p)`` per-angle design of eq 30 (m per rad/(N·m)).
    columns
        ``(joint, angle index or None)`` of each column (0-based joints).
    q2
        Distinct joint-2 angles (rad) the angle indices refer to.
    torque
        ``(r, 6)`` joint torques (N·m) the loads exert, one row per loaded configuration.
    torque_angle
        ``(r,)`` angle index of each row of ``torque``.
    """
    names = [angle_label(q2[a]) if a is not None else f"k{j + 1}" for j, a in columns]
    norms = np.linalg.norm(design, axis=0)
    largest_torque = float(np.abs(torque).max(initial=0.0))
    reasons: dict[str, str] = {}
    identifiable = norms > RANK_TOLERANCE * max(norms.max(initial=0.0), np.finfo(float).tiny)
    for i, (joint, angle) in enumerate(columns):
        if not identifiable[i]:
            reasons[names[i]] = _unloaded_reason(joint, angle, q2, torque, torque_angle, largest_torque)

    kept = np.flatnonzero(identifiable)
    scaled = design[:, kept] / norms[kept]
    singular = np.linalg.svd(scaled, compute_uv=False) if kept.size else np.empty(0)
    rank = int(np.sum(singular > RANK_TOLERANCE * singular.max(initial=0.0))) if kept.size else 0
    if kept.size and rank < kept.size:
        _, _, vt = np.linalg.svd(scaled)
        null = vt[rank:].T
        weight = np.linalg.norm(null, axis=1)
        confounded = kept[weight > 1e-6]
        for i in confounded:
            partners = [names[j] for j in confounded if j != i]
            reasons[names[i]] = (
                f"the campaign determines only a combination of {names[i]} with {', '.join(partners)}: "
                "their columns of the design are linearly dependent"
            )
            identifiable[i] = False
        kept = np.flatnonzero(identifiable)
        scaled = design[:, kept] / norms[kept]
        singular = np.linalg.svd(scaled, compute_uv=False)
    condition = float(singular.max() / singular.min()) if singular.size else math.inf
    vif = dict(zip([names[i] for i in kept], np.diag(np.linalg.inv(scaled.T @ scaled)))) if kept.size else {}

    joint2_angles = sorted({columns[i][1] for i in kept if columns[i][0] == 1})
    compensator = len(joint2_angles) >= _MIN_ANGLES
    if not compensator:
        listed = ", ".join(f"{math.degrees(q2[a]):.2f}" for a in joint2_angles) or "none"
        why = (
            f"the campaign has {len(joint2_angles)} q2 angle(s) with an identifiable joint-2 compliance "
            f"({listed} deg); K_theta2^0, K_c and s0*K_c of eq 34 need at least {_MIN_ANGLES}"
        )
        for name in ("k2", "K_c", "s0"):
            reasons[name] = why
    return Identifiability(
        names=names,
        identifiable=identifiable,
        rank=rank,
        condition_number=condition,
        vif={k: float(v) for k, v in vif.items()},
        reasons=reasons,
        compensator=compensator,
    )


def _unloaded_reason(joint: int, angle: int | None, q2, torque, torque_angle, largest: float) -> str:
    rows = torque[:, joint] if angle is None else torque[torque_angle == angle, joint]
    biggest = float(np.abs(rows).max(initial=0.0))
    where = "" if angle is None else f" at q2 = {math.degrees(q2[angle]):.2f} deg"
    if biggest <= _NO_TORQUE * largest:
        return (
            f"no load of the campaign{where} exerts a torque about the axis of joint {joint + 1} "
            f"(largest |tau{joint + 1}| = {biggest:.3g} N m against {largest:.3g} N m on other joints)"
        )
    return f"the markers do not move when joint {joint + 1} turns{where}: the design column is zero"
