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

That structural check says what the campaign could determine with perfect
data.  :func:`practical_reasons` judges, after sampling, what it did
determine: a parameter is *not identifiable from these data* when its
posterior is still essentially the prior.  For a parameter with a proper prior
this is measured by the contraction of its standard deviation: not identifiable
when the posterior sd exceeds :data:`CONTRACTION_LIMIT` (one half) of the prior
sd, i.e. the data have removed less than three quarters of the prior variance.
A flat prior on the positive half-line (joint compliances, ``K_c``) has no sd;
there the data must at least exclude zero, the value at which the parameter has
no effect: not identifiable when the ±3σ interval reaches zero (3 sd ≥ |mean|,
a relative width of 100 % or more).  A parameter that enters the model only
through another (``s0`` only through ``s0 K_c`` in eq 34) is not identifiable
when that one is not.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from bayescal.inference.parameters import angle_label, label_angle
from bayescal.robot.compensator import MIN_ANGLES, Compensator
from bayescal.robot.laws import CompensatorLaw

__all__ = [
    "Identifiability",
    "analyse",
    "angle_label",
    "label_angle",
    "practical_reasons",
    "grouped",
    "RANK_TOLERANCE",
    "ILL_CONDITIONED",
    "CONTRACTION_LIMIT",
    "PRACTICAL_RULE",
    "rule_clause",
    "independent_columns",
    "COLLINEAR_TOLERANCE",
]

RANK_TOLERANCE = 1e-8
"""Singular values of the unit-column information matrix's square root below this fraction of the largest count as zero."""
ILL_CONDITIONED = 1e4
"""Condition number of the unit-column design above which the estimates are flagged as fragile."""
_NO_TORQUE = 1e-6
"""A joint whose largest torque is below this fraction of the largest torque on any joint is taken as unloaded."""
CONTRACTION_LIMIT = 0.5
"""Posterior sd above this fraction of a proper prior's sd: the data have not determined the parameter."""
PRACTICAL_RULE = (
    "not identifiable from these data: posterior sd above 1/2 of a proper prior's sd, or, under a flat prior "
    "on the positive half-line, a ±3σ interval that includes 0; s0 whenever K_c is not identifiable (eq 34)"
)
"""The practical-identifiability rule in one line (the CLI's ``identifiability.rule``)."""
_SPRING_CLAUSE = "; s0 whenever K_c is not identifiable (eq 34)"
COLLINEAR_TOLERANCE = 1e-3
"""A column whose part not explained by the columns before it is below this fraction of its
norm adds nothing the data can resolve (its coefficient would be a ratio of noise to 1e-3)."""


@dataclass(frozen=True)
class Identifiability:
    """Result of :func:`analyse`.

    Attributes
    ----------
    names : list of str
        Per-angle parameter names (``k1``, ``k2_q2[<q2 in deg>]`` …, ``k6``).
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
        ``s0``) that the design cannot identify.
    compensator : bool
        Whether the design can identify ``K_theta2^0``, ``K_c`` and ``s0``; False without a compensator.
    practical : dict
        Reason for each parameter that the design could identify but the
        posterior does not determine (:func:`practical_reasons`); empty before sampling.
    rule_clause : str
        What the practical rule says of the compensator law's parameters (the spring's: s0 whenever K_c is not
        identifiable; :func:`rule_clause` of another law).
    """

    names: list[str]
    identifiable: np.ndarray
    rank: int
    condition_number: float
    vif: dict[str, float]
    reasons: dict[str, str] = field(default_factory=dict)
    compensator: bool = True
    practical: dict[str, str] = field(default_factory=dict)
    rule_clause: str = _SPRING_CLAUSE

    @property
    def not_identifiable(self) -> dict[str, str]:
        """Every parameter reported as not identifiable, structural reasons first."""
        return dict(self.reasons) | dict(self.practical)

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
            "not_identifiable": self.not_identifiable,
            "structural": sorted(self.reasons),
            # Without a compensator there is no spring to speak of.
            "rule": PRACTICAL_RULE.removesuffix(_SPRING_CLAUSE) + (self.rule_clause if self.compensated else ""),
        }

    @property
    def compensated(self) -> bool:
        """Whether the model has a compensated joint (per-angle columns), identifiable or not."""
        return any(label_angle(name) is not None for name in self.names)


def analyse(
    design: np.ndarray,
    columns: Sequence[tuple[int, int | None]],
    q2: np.ndarray,
    torque: np.ndarray,
    torque_angle: np.ndarray,
    prismatic: Sequence[bool] = (),
    unresolved: Mapping[int, str] | None = None,
    law: type | CompensatorLaw = Compensator,
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
        ``(r, nq)`` generalized forces the loads exert on the joints, one row per loaded
        configuration: torques (N·m), forces (N) along a prismatic joint.
    torque_angle
        ``(r,)`` angle index of each row of ``torque``.
    prismatic
        Which joints are prismatic; empty: all revolute.
    unresolved
        Column index → reason for columns the data resolve too poorly to keep
        (:func:`~bayescal.inference.fit_checks.unresolved_columns`): not identifiable, whatever their norm.
    law
        The compensator's law (its class or an instance): its parameters' names in the reasons.
    """
    names = [angle_label(q2[a], j) if a is not None else f"k{j + 1}" for j, a in columns]
    norms = np.linalg.norm(design, axis=0)
    identifiable, reasons = _vanishing(norms, names, columns, q2, torque, torque_angle, prismatic)
    for i, reason in (unresolved or {}).items():
        identifiable[i] = False
        reasons[names[i]] = reason

    kept = np.flatnonzero(identifiable)
    scaled = design[:, kept] / norms[kept]
    singular = np.linalg.svd(scaled, compute_uv=False) if kept.size else np.empty(0)
    rank = int(np.sum(singular > RANK_TOLERANCE * singular.max(initial=0.0))) if kept.size else 0
    if kept.size and rank < kept.size:
        _drop_confounded(scaled, kept, rank, names, identifiable, reasons)
        kept = np.flatnonzero(identifiable)
        scaled = design[:, kept] / norms[kept]
        singular = np.linalg.svd(scaled, compute_uv=False)
    condition = float(singular.max() / singular.min()) if singular.size else math.inf
    vif = dict(zip([names[i] for i in kept], np.diag(np.linalg.inv(scaled.T @ scaled)))) if kept.size else {}
    return Identifiability(
        names=names,
        identifiable=identifiable,
        rank=rank,
        condition_number=condition,
        vif={k: float(v) for k, v in vif.items()},
        reasons=reasons,
        compensator=_compensator_identifiable(columns, kept, q2, reasons, law),
    )


def _vanishing(norms, names, columns, q2, torque, torque_angle, prismatic) -> tuple[np.ndarray, dict[str, str]]:
    """Which columns (of ``norms``) do not vanish, and the reason of each that does (arguments as :func:`analyse`'s)."""
    linear = np.zeros(torque.shape[1], dtype=bool)
    linear[: len(prismatic)] = np.asarray(prismatic, dtype=bool)
    # A revolute joint's torque is compared with the other torques only.
    largest = {kind: float(np.abs(torque[:, linear == kind]).max(initial=0.0)) for kind in (False, True)}
    reasons: dict[str, str] = {}
    identifiable = norms > RANK_TOLERANCE * max(norms.max(initial=0.0), np.finfo(float).tiny)
    for i, (joint, angle) in enumerate(columns):
        if not identifiable[i]:
            reasons[names[i]] = _unloaded_reason(joint, angle, q2, torque, torque_angle, largest[bool(linear[joint])], bool(linear[joint]))
    return identifiable, reasons


def _drop_confounded(scaled: np.ndarray, kept: np.ndarray, rank: int, names: list[str], identifiable: np.ndarray, reasons: dict[str, str]) -> None:
    """Mark the kept columns with a component in the null space of the unit-column design ``scaled`` not
    identifiable, in ``identifiable`` and ``reasons``, naming the columns each is confounded with."""
    # U is not needed: only a short, wide design needs the full V to span its null space.
    _, _, vt = np.linalg.svd(scaled, full_matrices=scaled.shape[0] < scaled.shape[1])
    null = vt[rank:].T
    weight = np.linalg.norm(null, axis=1)
    confounded = kept[weight > 1e-6]
    # Columns i and j are confounded together when the null space links them.
    link = np.abs(null @ null.T)
    for i in confounded:
        row = np.flatnonzero(kept == i)[0]
        partners = [names[kept[col]] for col in np.flatnonzero(link[row] > 1e-6) if kept[col] != i]
        reasons[names[i]] = (
            f"the campaign determines only a combination of {names[i]} with {', '.join(partners)}: "
            "their columns of the design are linearly dependent"
        )
        identifiable[i] = False


def rule_clause(law) -> str:
    """The practical rule's words on a compensator ``law``'s dependent parameters (``; s0 whenever K_c …``)."""
    return "".join(f"; {name} whenever {other} is not identifiable (eq 34)" for name, other in law.REQUIRES.items())


def _compensator_identifiable(columns: Sequence[tuple[int, int | None]], kept: np.ndarray, q2: np.ndarray, reasons: dict[str, str], law) -> bool:
    """Whether the kept columns hold :data:`~bayescal.robot.compensator.MIN_ANGLES` angles of the compensated joint; if not, the reason is
    added to ``reasons`` for that joint's compliance and the ``law``'s parameters (K_c and s0)."""
    # Only the compensated joint's compliance has one column per angle; without a compensator no column has
    # one, and nothing is said about K_c and s0.
    per_angle_joint = next((j for j, angle in columns if angle is not None), None)
    joint2_angles = sorted({columns[i][1] for i in kept if columns[i][1] is not None})
    compensator = len(joint2_angles) >= MIN_ANGLES
    if not compensator and per_angle_joint is not None:
        listed = ", ".join(f"{math.degrees(q2[a]):.2f}" for a in joint2_angles) or "none"
        j = per_angle_joint + 1
        why = (
            f"the campaign has {len(joint2_angles)} q{j} angle(s) with an identifiable joint-{j} compliance "
            f"({listed} deg); K_theta{j}^0, {' and '.join(law.LINEAR)} of eq 34 need at least {MIN_ANGLES}"
        )
        for name in (f"k{per_angle_joint + 1}", *(p.name for p in law.PARAMETERS)):
            reasons[name] = why
    return compensator


def _unloaded_reason(joint: int, angle: int | None, q2, torque, torque_angle, largest: float, prismatic: bool = False) -> str:
    rows = torque[:, joint] if angle is None else torque[torque_angle == angle, joint]
    biggest = float(np.abs(rows).max(initial=0.0))
    where = "" if angle is None else f" at q{joint + 1} = {math.degrees(q2[angle]):.2f} deg"
    # A slide's force (N) is set against the largest force or torque over a 1 m arm (N·m / m) on any joint.
    if prismatic and biggest <= _NO_TORQUE * max(largest, float(np.abs(torque).max(initial=0.0))):
        return (
            f"no load of the campaign{where} exerts a force along the axis of the prismatic joint {joint + 1} "
            f"(largest |f{joint + 1}| = {biggest:.3g} N)"
        )
    if prismatic:
        return f"the markers do not move when joint {joint + 1} slides{where}: the design column is zero"
    if biggest <= _NO_TORQUE * largest:
        return (
            f"no load of the campaign{where} exerts a torque about the axis of joint {joint + 1} "
            f"(largest |tau{joint + 1}| = {biggest:.3g} N m against {largest:.3g} N m on other joints)"
        )
    return f"the markers do not move when joint {joint + 1} turns{where}: the design column is zero"


def _undetermined(row: pd.Series, prior: float | None) -> str | None:
    """Why one parameter's posterior ``row`` leaves it undetermined (its ±3σ interval includes 0 under a flat prior,
    or its sd is mostly its proper prior's), or None when the data determine it."""
    mean, sd, unit = float(row["mean"]), float(row["sd"]), str(row["unit"])
    # Rounded as every shown interval is: to the decimal of the second significant digit of its 3 sd.
    places = max(0, 1 - math.floor(math.log10(3.0 * sd))) if sd > 0 and math.isfinite(sd) else 0
    interval = f"[{row['lo3']:.{places}f}, {row['hi3']:.{places}f}] {unit}".rstrip()
    if prior is None:
        if 3.0 * sd < abs(mean):
            return None
        if mean:
            return f"its ±3σ interval {interval} includes 0 (3 sd = {300.0 * sd / abs(mean):.0f} % of the mean)"
        return f"its ±3σ interval {interval} is centred on 0"
    if sd <= CONTRACTION_LIMIT * prior:
        return None
    return (
        f"its posterior sd {sd:.4g} {unit} is {sd / prior:.2f} of its prior's {prior:.4g} {unit} "
        f"(more than {CONTRACTION_LIMIT:g}): the posterior is mostly the prior"
    )


def practical_reasons(
    summary: pd.DataFrame,
    prior_sd: Mapping[str, float | None],
    *,
    requires: Mapping[str, str] | None = None,
    context: Mapping[str, str] | None = None,
    through: Mapping[str, str] | None = None,
) -> dict[str, str]:
    """The parameters a posterior leaves undetermined, each with its reason in numbers.

    Parameters
    ----------
    summary
        Posterior summary indexed by parameter with ``mean``, ``sd``, ``lo3``,
        ``hi3`` and ``unit`` (:func:`bayescal.sampling.summary.summarize`).
    prior_sd
        The parameters to judge: the sd of each one's proper prior (in the unit of
        ``summary``), or None for a flat prior on the positive half-line.
    requires
        ``{name: other}``: ``name`` enters the model only through ``other`` and is
        not identifiable whenever ``other`` is not.
    context
        Extra explanation (why the data are weak) prepended to a parameter's reason
        when it fails.
    through
        ``{name: words}``: how ``name`` enters the model through its ``requires``' other (default: the product of
        the two, as s0 through s0·K_c).

    Returns
    -------
    dict
        ``{name: reason}`` for the parameters that fail, in the order of ``prior_sd``.
    """
    requires = dict(requires or {})
    context = dict(context or {})
    reasons: dict[str, str] = {}
    for name, prior in prior_sd.items():
        if name not in summary.index:
            continue
        why = _undetermined(summary.loc[name], prior)
        if why is not None:
            reasons[name] = f"{context[name]}; {why}" if name in context else why
    for name, other in requires.items():
        if other in reasons and name in summary.index:
            how = (through or {}).get(name, f"the product {name}·{other}")
            why = f"{name} enters the model only through {how}, and {other} is not identifiable from these data"
            reasons[name] = why + (f"; besides, {reasons[name]}" if name in reasons else "")
    return {name: reasons[name] for name in prior_sd if name in reasons}


def grouped(reasons: Mapping[str, str]) -> list[tuple[list[str], str]]:
    """``[(names, reason)]``: parameters that share a reason listed together, in first-seen order."""
    groups: dict[str, list[str]] = {}
    for name, reason in reasons.items():
        groups.setdefault(reason, []).append(name)
    return [(names, reason) for reason, names in groups.items()]


def independent_columns(X: np.ndarray) -> np.ndarray:
    """Indices of the columns of ``X`` kept in order, each dropped if it is (nearly) a combination of those kept before."""
    kept: list[int] = []
    # the orthonormal basis of the kept columns, filled in place: grown by a copy per column it took 0.43 s
    # on a 270,000 × 20 design (10,000 configurations, 3 markers, 3 repeats), in place 0.21 s
    basis = np.empty_like(X, dtype=float)
    for j in range(X.shape[1]):
        column = X[:, j]
        norm = np.linalg.norm(column)
        if norm == 0:
            continue
        known = basis[:, : len(kept)]
        rest = column - known @ (known.T @ column)
        if np.linalg.norm(rest) > COLLINEAR_TOLERANCE * norm:
            basis[:, len(kept)] = rest / np.linalg.norm(rest)
            kept.append(j)
    return np.array(kept, dtype=int)
