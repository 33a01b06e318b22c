"""Model criticism of the compensator-geometry model: what the planar arc model gets wrong on tracker points.

``GeometryCritique().run(points)`` starts from the model the package identifies
the compensator geometry with (:mod:`bayescal.geometry.arcs`) and compares it
with physical extensions by how well each predicts the markers at a joint-2
angle its fit did not see, with the rule of the elastostatic critique
(:mod:`bayescal.critique.model`).

**The marker layout.**  Every model predicts every marker at any q2 (SI, the
tracker's (x, y)):

* the lever marker ``P1 = p2 + L·[cos(phi + κ q2), sin(phi + κ q2)]`` (eq 10,
  ``κ = ±1`` the arc's sense, fixed by the closed-form fit);
* each cylinder marker ``P0k = p0 + R_k·[cos(θ + δ_k), sin(θ + δ_k)]``, ``θ``
  the direction of the cylinder ``P1 - p0``: rigid on the cylinder at the
  polar offset ``(R_k, δ_k)``, as :class:`~bayescal.geometry.arcs.MarkerLayout`.

Parameters: ``p2`` (2, m), ``L`` (m), ``phi`` (rad), ``p0`` (2, m), ``R_k``
(m) and ``δ_k`` (rad) per cylinder marker: 10 on Table I.

**The base model** is the package's two-step identification: P1 alone by the
known-angle arc fit (eqs 10-19), then the cylinder markers with the lever held
fixed.  The paper's concentric step (eqs 20-24) leaves the cylinder markers'
angles free and so cannot say where a marker will be at another q2; the base
takes them from the lever as above, which is also how the package simulates
Table-I-like campaigns, and fits ``p0, R_k, δ_k`` by least squares on the
points (starting from the concentric fit).

**Candidate extensions** (:data:`GEOMETRY_CATALOGUE`), each added to the
current model:

* ``tilt``: the compensator's plane is tilted against the tracker's XY by
  ``t`` about an in-plane axis at angle ``psi``, so every arc projects as an
  ellipse shortened by ``cos t`` across that axis.  The projection is
  ``p ↦ p2 + (I - [[a, b], [b, -a]]) (p - p2)``: its isotropic part is a scale
  the layout's lengths absorb, the anisotropic part ``(a, b) = (1 - cos t)/2
  · (cos 2ψ', sin 2ψ')`` (``ψ' = psi + 90°``, the shortened direction) is
  what the data can see.  2 parameters (dimensionless); reported as ``t`` and
  ``psi`` in deg.
* ``pivot_motion``: the pivot p0 moves under the spring force, whose
  magnitude ``K_c (s - s0)`` is linear in the spring length ``s = |P1 - p0|``:
  ``p0(q2) = p0 + (s - a) g`` with ``a = |p2 - p0|`` (the constant part
  ``(a - s0) g`` is in ``p0``) and ``g`` a fixed direction and size of the
  support's compliance in the tracker frame.  2 parameters (m of pivot shift
  per m of spring length; reported in μm/mm).  A shift along the cylinder's own
  axis is indistinguishable from the markers sliding along it, which
  ``cylinder_slip`` models; ``g`` is fixed in the frame, so the two differ by
  how the cylinder turns.
* ``cylinder_slip``: the markers are not rigid on the cylinder: their
  distance from p0 and their angle from the cylinder's direction vary
  linearly with the spring length, ``R_k + λ (s - a)``, ``δ_k + ω (s - a)``,
  the same for every cylinder marker (they sit on one housing).  2 parameters:
  ``λ`` (dimensionless, reported in μm/mm) and ``ω`` (rad/m, reported in
  mdeg/mm).
* ``joint_scale``: the lever turns by ``(1 + e) q2`` where q2 is read: a gain
  error of the joint-2 angle, or a deflection of joint 2 growing with q2.
  The cylinder markers follow the lever.  1 parameter ``e`` (dimensionless,
  reported in %).  Added because a lever misfit that ``tilt`` explains could
  come from the angles instead.
* ``closed_loop``: no new parameter; all parameters estimated together from
  all markers (the loop P0-P1-P2 ties the cylinder markers' angles to the
  lever, so their points inform p2, L and phi too) instead of in two steps.
  Once named, every later model is fitted jointly.

**Probes** (:data:`GEOMETRY_PROBES`): displacements of the lever marker and
of the cylinder markers along their arcs' radius and tangent, linear in a
standardised covariate (``q2``, or the square of q2's distance from the
campaign's mean: ``q2_squared``), 4 parameters (m).  Not physics: they
only name what a misfit that no extension explains follows.

**Noise.** One σ per marker group (``lever``: P1; ``cylinder``: P0k), each
with ``n_g - p_g`` degrees of freedom, ``p_g`` the parameters of the step
that fits the group (the lever's and the tilt's for ``lever``, the rest for
``cylinder``), ``σ_g² = SS_g / (n_g - p_g)``.

**Held-out comparison** (leave-one-angle-out: every marker measured at one q2
held out together): the predictive density of a held-out angle is, per marker
group, a multivariate Student t with the group's degrees of freedom, located
at the prediction, with scale ``σ_g² I + J Σ J'``: ``Σ`` the parameters'
linearised (Laplace) covariance, propagated through the two steps for a
two-step fit, ``J`` the prediction's Jacobian.  The groups' densities are
multiplied (their correlation through the shared parameters, small beside the
noise, is neglected).  ΔELPD and its SE are those of
:func:`bayescal.critique.compare.compare_elpd` over the held-out angles.

**Rule**: :data:`~bayescal.critique.rule.DETECTION_Z` SE and
:data:`~bayescal.critique.rule.DETECTION_FLOOR` nats, greedy as the
elastostatic critique, without its decisive branch: none of the candidates is
about heavy tails, and with a handful of angles the held-out end angles are
extrapolations, where one angle can carry any gain.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from typing import NamedTuple
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.critique.compare import Comparison, compare_elpd
from bayescal.critique.layout_fit import _GROUPS, LayoutFit, _fit, _group_rows, _Spec, _TooFewDegrees
from bayescal.critique.results import Outcome
from bayescal.critique.rule import DETECTION_FLOOR, DETECTION_Z, UNEXPLAINED, check_candidates, strongest
from bayescal.errors import InputError
from bayescal.geometry.arcs import MarkerPoints
from bayescal.summary import Summary
from bayescal.units import DEG, MM

__all__ = [
    "GEOMETRY_CATALOGUE",
    "GEOMETRY_PROBES",
    "MIN_ANGLES",
    "GeometryCritique",
    "GeometryCritiqueResults",
    "LayoutFit",
]

GEOMETRY_CATALOGUE = {
    "tilt": "the compensator plane tilted against the tracker's XY: arcs project as ellipses",
    "pivot_motion": "the pivot P0 moving in proportion to the spring force",
    "cylinder_slip": "cylinder markers' distance from P0 and angle from the cylinder axis varying with the spring length",
    "joint_scale": "the lever turning by (1 + e) q2: a joint-2 angle scale error",
    "closed_loop": "all markers fitted jointly through the loop P0-P1-P2 instead of in two steps",
}
"""The candidate extensions, by name, with what each models."""

GEOMETRY_PROBES = {
    "q2": "an offset along the arcs' radius and tangent linear in q2",
    "q2_squared": "an offset along the arcs' radius and tangent quadratic in q2 (about the campaign's mean angle)",
}
"""The covariates an unexplained misfit is checked against."""

MIN_ANGLES = 5
"""Fewest joint angles at which every marker must be measured: the held-out comparison fits
each model to all angles but one, and a two-step base with a tilt needs 6 parameters for
the lever's 2 coordinates per angle, leaving 2 degrees of freedom of its noise at 4 angles."""
JSON_DIGITS = 6
"""Significant digits of the estimates and residual statistics in :meth:`GeometryCritiqueResults.to_json`
(6 keep 1 μm on a 700 mm a_x)."""


def _rounded(values: dict[str, float]) -> dict[str, float]:
    return {key: float(f"{value:.{JSON_DIGITS}g}") for key, value in values.items()}


# --------------------------------------------------------------------------- the models


@dataclass(frozen=True)
class AngleValidation:
    """A model left-one-angle-out.

    Attributes
    ----------
    angles : numpy.ndarray
        ``(K,)`` the held-out joint angles (rad), in the order of ``elpd``.
    elpd : numpy.ndarray
        ``(K,)`` log predictive density of each angle's points with the model fitted to the others.
    residual : numpy.ndarray
        ``(n, 2)`` held-out residual of every point (measured minus predicted), m.
    full : LayoutFit
        The model fitted to all points.
    """

    angles: np.ndarray
    elpd: np.ndarray
    residual: np.ndarray
    full: LayoutFit

    @property
    def total(self) -> float:
        return float(self.elpd.sum())


def _subset(points: MarkerPoints, keep: np.ndarray) -> MarkerPoints:
    return MarkerPoints(points.marker[keep], points.q2[keep], points.xyz[keep], points.line[keep], points.source)


def _validate(points: MarkerPoints, spec: _Spec, reference: np.ndarray) -> AngleValidation:
    angles = np.unique(points.q2)
    elpd = np.empty(angles.size)
    residual = np.empty((points.q2.size, 2))
    for k, angle in enumerate(angles):
        out = points.q2 == angle
        fitted = _fit(_subset(points, ~out), spec, reference)
        held = points.xyz[out, :2]
        elpd[k] = fitted.log_density(points.q2[out], points.marker[out], held)
        residual[out] = held - fitted.predict(points.q2[out], points.marker[out])
    return AngleValidation(angles, elpd, residual, _fit(points, spec, reference))


def _residual_statistics(points: MarkerPoints, validation: AngleValidation) -> dict:
    """Held-out residual rms (per coordinate, mm) per marker group and per marker."""
    out = {}
    for group, rows in _group_rows(points.marker).items():
        out[f"residual_rms_{group}_mm"] = float(np.sqrt(np.mean(validation.residual[rows] ** 2)) / MM)
    for name in points.markers:
        rows = points.marker == name
        out[f"residual_rms_{name}_mm"] = float(np.sqrt(np.mean(validation.residual[rows] ** 2)) / MM)
    out["residual_rms_mm"] = float(np.sqrt(np.mean(validation.residual**2)) / MM)
    return out


# --------------------------------------------------------------------------- the critique


class _Selection(NamedTuple):
    """What the forward selection over the catalogue ended with."""

    spec: _Spec
    final: AngleValidation
    causes: list[str]
    """The extensions added, in order."""
    steps: list[dict[str, Comparison]]
    """Each round's comparisons of the extensions tried against the model so far."""
    estimates: dict[str, dict[str, float]]
    leads: dict[str, tuple[str, Comparison]]
    """Each cause's runner-up and its lead over it."""
    skipped: list[str]
    """Extensions left out for lack of degrees of freedom."""


@dataclass
class GeometryCritique:
    """Criticism of the planar two-step compensator-geometry model on tracker points.

    Parameters
    ----------
    catalogue
        The extensions to try, by name; default all of :data:`GEOMETRY_CATALOGUE`.
    probes
        The covariates an unexplained misfit is checked against; default all of :data:`GEOMETRY_PROBES`.
    """

    catalogue: tuple[str, ...] = tuple(GEOMETRY_CATALOGUE)
    probes: tuple[str, ...] = tuple(GEOMETRY_PROBES)

    def __post_init__(self) -> None:
        check_candidates(self.catalogue, GEOMETRY_CATALOGUE)
        check_candidates(self.probes, GEOMETRY_PROBES)

    def run(self, points: MarkerPoints) -> GeometryCritiqueResults:
        """Criticise the two-step model on ``points`` (see :func:`bayescal.geometry.arcs.read_arc_points`).

        Points with z are criticised in (x, y), with a ``UserWarning``.

        Raises
        ------
        InputError
            When a marker is measured at fewer than :data:`MIN_ANGLES` joint angles.
        """
        _check_angles(points)
        if points.dim == 3:
            warnings.warn("the geometry critique is planar: it uses x and y and ignores z_mm", UserWarning, stacklevel=2)
        reference = np.unique(points.q2)
        base = _validate(points, _Spec(), reference)
        selection = self._select(points, reference, base)
        spec, current, causes, skipped = selection.spec, selection.final, selection.causes, selection.skipped
        probes = {}
        for name in self.probes:
            try:
                probes[name] = compare_elpd(current.elpd, _validate(points, spec.with_probe(name), reference).elpd)
            except _TooFewDegrees:
                skipped.append(name)
        covariate = strongest(probes, decisive=False)
        if covariate is not None:
            causes.append(UNEXPLAINED)
        return GeometryCritiqueResults(
            causes=causes,
            unexplained_covariate=covariate,
            steps=selection.steps,
            probes=probes,
            estimates=selection.estimates,
            leads=selection.leads,
            skipped=sorted(set(skipped)),
            base=base,
            final=current,
            gain=compare_elpd(base.elpd, current.elpd),
            before=_residual_statistics(points, base),
            after=_residual_statistics(points, current),
            n_angles=reference.size,
            n_points=points.q2.size,
            residuals=_residual_table(points, base, current),
            source=points.source or "",
        )

    def _select(self, points: MarkerPoints, reference: np.ndarray, base: AngleValidation) -> _Selection:
        """Forward selection over the catalogue: add the extension that most improves the held-out ELPD while one does."""
        spec, current = _Spec(), base
        causes: list[str] = []
        steps: list[dict[str, Comparison]] = []
        estimates: dict[str, dict[str, float]] = {}
        leads: dict[str, tuple[str, Comparison]] = {}
        skipped: list[str] = []
        remaining = list(self.catalogue)
        while remaining:
            trials = {}
            for name in remaining:
                try:
                    trials[name] = _validate(points, spec.plus(name), reference)
                except _TooFewDegrees:
                    skipped.append(name)
            remaining = [name for name in remaining if name in trials]
            evidence = {name: compare_elpd(current.elpd, cv.elpd) for name, cv in trials.items()}
            if not evidence:
                break
            steps.append(evidence)
            for name, cv in trials.items():
                estimates[name] = cv.full.extension_parameters()
            best = strongest(evidence, decisive=False)
            if best is None:
                break
            runner_up = strongest({name: c for name, c in evidence.items() if name != best}, decisive=False)
            if runner_up is not None:
                leads[best] = (runner_up, compare_elpd(trials[runner_up].elpd, trials[best].elpd))
            spec, current = spec.plus(best), trials[best]
            causes.append(best)
            remaining = [name for name in remaining if name != best]
        return _Selection(spec, current, causes, steps, estimates, leads, skipped)


def _check_angles(points: MarkerPoints) -> None:
    """Every marker is measured at :data:`MIN_ANGLES` joint angles or more (one is held out at a time)."""
    for name in points.markers:
        n = np.unique(points.of(name)[0]).size
        if n < MIN_ANGLES:
            raise InputError(
                f"marker {name} is measured at {n} joint angles; the critique holds out one angle at a time "
                f"and needs at least {MIN_ANGLES}",
                source=points.source,
                column="q2_deg",
            )


def _residual_table(points: MarkerPoints, base: AngleValidation, final: AngleValidation) -> pd.DataFrame:
    """One row per point: its marker and angle, and its held-out residual (mm) under the two-step and the final model."""
    return pd.DataFrame(
        {
            "marker": points.marker,
            "q2_deg": points.q2 / DEG,
            "two_step_x_mm": base.residual[:, 0] / MM,
            "two_step_y_mm": base.residual[:, 1] / MM,
            "final_x_mm": final.residual[:, 0] / MM,
            "final_y_mm": final.residual[:, 1] / MM,
        }
    )


@dataclass
class GeometryCritiqueResults(Outcome):
    """What the geometry critique found (:class:`~bayescal.critique.results.Outcome`, and the following).

    Attributes
    ----------
    estimates : dict
        For each candidate, the extension parameters of the model with it (at its last step), fitted to
        all points, in reporting units named in the keys.
    leads : dict
        For each named cause that another candidate also passed at its step: that runner-up and the
        held-out comparison of the cause against it (how clearly the data prefer one to the other).
    skipped : list of str
        Candidates not tried because they would leave a marker group fewer than :data:`MIN_DOF` degrees of freedom.
    base, final : AngleValidation
        The two-step model and the final model, left-one-angle-out.
    gain : Comparison
        The final model against the base on held-out angles.
    before, after : dict
        Held-out residual rms (per coordinate, mm) of the base and the final model.
    residuals : pandas.DataFrame
        One row per point: ``marker``, ``q2_deg`` and the held-out residuals ``two_step_x_mm``,
        ``two_step_y_mm``, ``final_x_mm``, ``final_y_mm``.
    """

    estimates: dict[str, dict[str, float]]
    leads: dict[str, tuple[str, Comparison]]
    skipped: list[str]
    base: AngleValidation
    final: AngleValidation
    gain: Comparison
    before: dict
    after: dict
    n_angles: int
    n_points: int
    residuals: pd.DataFrame
    source: str = ""
    rule: dict = field(default_factory=lambda: {"z": DETECTION_Z, "floor_nats": DETECTION_FLOOR})

    def to_json(self) -> dict:
        """The elastostatic critique's JSON shape; held-out units are joint angles (``n_configs`` counts them)."""
        evidence = {}
        for step_number, step in enumerate(self.steps, start=1):
            for name, c in step.items():
                evidence[name] = c.to_json() | {
                    "step": step_number,
                    "named": name in self.causes,
                    "meaning": GEOMETRY_CATALOGUE[name],
                    "estimate": _rounded(self.estimates.get(name, {})),
                }
                if name in self.leads:
                    runner_up, lead = self.leads[name]
                    evidence[name]["lead_over_runner_up"] = {"candidate": runner_up} | lead.to_json()
        payload = {
            "verdict": self.verdict,
            "causes": list(self.causes),
            "evidence": evidence,
            "gain": self.gain.to_json()
            | {"held_out": "leave-one-angle-out", "before": _rounded(self.before), "after": _rounded(self.after)},
            "covariates": {name: c.to_json() | {"meaning": GEOMETRY_PROBES[name]} for name, c in self.probes.items()},
            "geometry": {"two_step": _rounded(self.base.full.geometry()), "final": _rounded(self.final.full.geometry())},
            "noise_mm": {
                "before": _rounded({group: self.base.full.sigma[group] / MM for group in _GROUPS}),
                "after": _rounded({group: self.final.full.sigma[group] / MM for group in _GROUPS}),
            },
            "rule": {"delta_elpd_over_se": DETECTION_Z, "floor_nats": DETECTION_FLOOR},
            "n_angles": self.n_angles,
            "n_points": self.n_points,
            "points": self.source,
        }
        if self.skipped:
            payload["not_tried"] = list(self.skipped)
        if self.unexplained_covariate is not None:
            payload["unexplained_covariate"] = self.unexplained_covariate
        return payload

    def document(self) -> Summary:
        """What the geometry critique found as one document (:mod:`bayescal.summary`): the text
        ``bayescal critique --geometry`` prints, and its Markdown, HTML and JSON."""
        from bayescal.critique.document import geometry_critique_document

        return geometry_critique_document(self)

    def diagnostics(self) -> dict:
        """What the comparison rests on: held-out angles and points, the candidates not tried, the decision
        rule, and the held-out residual rms (mm) of the two-step and the final model over all markers."""
        return {
            "n_angles": self.n_angles,
            "n_points": self.n_points,
            "skipped": list(self.skipped),
            "rule": dict(self.rule),
            "held_out_rms_mm": {"two_step": self.before.get("residual_rms_mm"), "final": self.after.get("residual_rms_mm")},
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to ``path``."""
        Path(path).write_text(json.dumps(self.to_json(), indent=2, allow_nan=False) + "\n")
