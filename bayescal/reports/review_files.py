"""The review's sections for the JSON files it is given: a plan, a critique and a registration, as findings records.

``bayescal plan --json`` and ``bayescal critique --json`` print findings, read back as
:class:`~bayescal.design.plan_design.PlanFindings` and :class:`~bayescal.critique.results.CritiqueFindings`
(``bayescal axes -o``'s file as :class:`~bayescal.registration.register.RegistrationFindings`); these
sections put their known fields in words and tables rounded to their uncertainty
(the criterion in μm, the ±3σ widths to two digits, ΔELPD and SE to 0.1 nat),
and show any other key of the file in a generic table under its name in words, so that a
file from a newer version still renders.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from bayescal.reports.figures import plot_evidence
from bayescal.numbers import fixed, rounded_pair, table_texts
from bayescal.reports.page import Page, finite_number, generic
from bayescal.reports.terms import label

if TYPE_CHECKING:
    from bayescal.critique.results import CritiqueFindings
    from bayescal.design.plan_design import PlanFindings
    from bayescal.registration.register import RegistrationFindings

__all__ = ["plan_section", "critique_section", "registration_section"]

PLAN_SHOWN = ("criterion", "criterion_unit", "criterion_includes", "criterion_identified_only", "criterion_prior_share_of_mean_square", "parameters", "optimised_for", "search_model", "model", "configurations", "repeats",
              "q2_deg", "load_kg", "linear_model")
"""Keys of the plan's JSON the plan section shows in words; any other is shown as it comes."""
CRITIQUE_SHOWN = ("verdict", "causes", "evidence", "gain", "covariates", "lack_of_fit", "rule", "n_configurations",
                  "n_equations", "tied_with", "contested_by", "explains", "shared_by_state", "by_repeats", "seed", "campaign")
"""Keys of the critique's JSON the critique section shows in words."""


def plan_section(page: Page, plan: PlanFindings, source: str) -> None:
    """The plan ``bayescal plan --json`` printed: what it was designed for, its angles, the predicted widths."""
    page.heading("plan", "Experiment plan")
    if source:
        page.paragraph(f"From {source}.")
    criterion, unit = plan.criterion, str(plan.criterion_unit if "criterion_unit" in plan.keys else "")
    page.record("criterion", criterion)
    page.record("criterion_unit", unit)
    if finite_number(criterion):
        linear = plan.linear_model.get("criterion") if isinstance(plan.linear_model, Mapping) else None
        designed = (
            f"Designed for the {plan.optimised_for} criterion"
            + (f" (searched with the {plan.search_model} model)" if "search_model" in plan.keys else "")
            if "optimised_for" in plan.keys
            else "Scored"
        )
        identified = plan.criterion_identified_only
        share = plan.criterion_prior_share_of_mean_square
        page.paragraph(
            f"{designed}: predicted ρ0 = {_criterion_text(criterion, unit)} (linearised at the design, the exact model; "
            "everything counted)"
            + (f"; the linear model of eq 31 predicts {_criterion_text(linear, unit)}" if finite_number(linear) else "")
            + (
                f". From the plan's data alone {_criterion_text(identified, unit)}; the rest ({share:.0%} of the mean square) "
                f"from {str(plan.criterion_includes if 'criterion_includes' in plan.keys else '').split('the prior of ', 1)[-1]}"
                if finite_number(identified) and finite_number(share) and share > 0
                else ""
            )
            + ".",
            css="verdict",
        )
    angles = plan.q2_deg
    if isinstance(angles, list) and angles:
        loads = plan.load_kg
        page.paragraph(
            f"{plan.configurations} configurations, each measured {plan.repeats if 'repeats' in plan.keys else '?'} times, at q2 = "
            + ", ".join(f"{v:.1f}" for v in angles)
            + " deg"
            + (f"; hanging loads of {', '.join(f'{v:g}' for v in loads)} kg" if isinstance(loads, list) and loads else "")
            + "."
        )
    if plan.parameters:
        _plan_widths(page, plan.parameters)
    starts = plan.starts
    if isinstance(starts, list) and starts and "candidates" in plan.keys and plan.optimised_for == "test-pose":
        # The starts hold the optimised criterion in SI: ρ0 in m for the test-pose criterion.
        reached = ", ".join(_criterion_text(v * 1e3, "mm rms") if finite_number(v) else "–" for v in starts)
        model = f", by the {plan.search_model} model's reckoning" if "search_model" in plan.keys else ""
        page.paragraph(f"Search: {plan.candidates} candidate configurations; the {len(starts)} random starts reached {reached}{model}.")
    # For the test-pose criterion the optimised value is ρ0 itself, in m: shown above in μm.
    shown = PLAN_SHOWN + (("starts", "candidates", "criterion_value") if plan.optimised_for == "test-pose" else ())
    rest = {key: value for key, value in plan.to_json().items() if key not in shown}
    if rest:
        generic(page, rest)
    page.close()


def _criterion_text(value: float, unit: str) -> str:
    """A criterion value in its unit; an rms error in mm is shown in μm (to 0.01 μm: a plan's predictions differ by tenths)."""
    if unit.startswith("mm rms"):
        return f"{value * 1000:.2f} μm rms"
    return f"{value:.4g} {unit}".strip()


def _plan_widths(page: Page, parameters: Mapping) -> None:
    columns = ("value", "width_3sd", "width_3sd_pct", "excited", "unit")
    frame = pd.DataFrame.from_dict(
        {name: {key: entry.get(key) for key in columns} for name, entry in parameters.items() if isinstance(entry, Mapping)}, orient="index"
    ).astype({"value": float, "width_3sd": float, "width_3sd_pct": float})
    frame["unit"] = frame["unit"].fillna("").str.replace("urad/(N m)", "μrad/(N·m)", regex=False)
    frame.index.name = "parameter"
    # A stiffness, a free length or a compliance cannot be negative: an interval that would reach below 0 is flagged.
    below = frame["value"] - frame["width_3sd"] < 0
    frame["lower_end"] = ["cut at 0: cannot be negative; the plan does not bound it from below" if b else "" for b in below]
    page.table(
        "parameters",
        frame,
        shown=table_texts(frame, {"width_3sd": "width_3sd"}, {"width_3sd_pct": fixed(1)}),
        caption="Predicted ±3σ of each parameter after measuring this plan, about the cell's nominal value",
        words=lambda key: {"width_3sd": "predicted ±3σ", "lower_end": "lower end"}.get(key, label(key)),
    )


def critique_section(page: Page, critique: CritiqueFindings, source: str) -> None:
    """The critique ``bayescal critique --json`` printed: verdict, next step, evidence, lack of fit, gain."""
    from bayescal.critique.document import by_repeats_clause

    page.heading("critique", "Critique of the model")
    if source:
        page.paragraph(f"From {source}.")
    causes = critique.causes
    named = [str(c) for c in causes] if isinstance(causes, list) and all(isinstance(c, str) for c in causes) else None
    verdict = str(critique.verdict)
    page.paragraph(
        f"Verdict: {verdict}" + (f": causes in order of gain: {', '.join(named)}" if named else "")
        + (" (no extension predicts held-out configurations clearly better than the calibrated model)" if verdict == "adequate" else ""),
        css="verdict",
    )
    page.record("verdict", verdict)
    if named is not None:
        page.record("causes", named)
    elif causes is not None:
        generic(page, {"causes": causes})
    advice = _next_step(critique, named)
    if advice:
        page.paragraph(advice)
    _rivals(page, critique, source)
    _shared_by_state(page, critique)
    _by_repeats(page, critique)
    _evidence(page, critique.evidence)
    _lack_of_fit(page, critique.lack_of_fit)
    _gain(page, critique.gain)
    covariates = critique.covariates
    if isinstance(covariates, Mapping) and covariates and all(isinstance(v, Mapping) for v in covariates.values()):
        frame = _elpd_frame(covariates, ("meaning",))
        frame.index.name = "covariate"
        _elpd_table(page, "covariates", frame, "Held-out gain of a smooth term in each covariate: what an effect outside the catalogue would follow")
    rule = critique.rule
    if isinstance(rule, Mapping) and {"delta_elpd_over_se", "floor_nats"} <= set(rule):
        page.paragraph(
            f"Rule: a cause is named when ΔELPD > {rule['delta_elpd_over_se']:g} SE and > {rule['floor_nats']:g} nats"
            + (f", or > {rule['decisive_nats']:g} nats" if "decisive_nats" in rule else "")
            + (f" and > {rule['decisive_over_se']:g} SE" if "decisive_over_se" in rule else "")
            + (by_repeats_clause(rule["by_repeats_over_se"], rule["floor_nats"]) if "by_repeats_over_se" in rule else "") + "."
        )
    rest = {key: value for key, value in critique.to_json().items() if key not in CRITIQUE_SHOWN}
    if rest:
        generic(page, rest)
    page.close()


def _next_step(critique: CritiqueFindings, named: list[str] | None) -> str:
    """The critique's next step, from the findings in its file (the same sentence ``bayescal critique`` prints)."""
    from bayescal.inference.next_steps import critique_next_steps

    gain = critique.gain
    test_pose = gain.get("test_pose") if isinstance(gain, Mapping) else None
    error = test_pose.get("classical_error_mm") if isinstance(test_pose, Mapping) else None
    lack = critique.lack_of_fit
    if named is None or not finite_number(error):
        return ""
    misfit = isinstance(lack, Mapping) and finite_number(lack.get("p_value")) and lack["p_value"] < lack.get("level", 0.01)
    negligible = critique.negligible
    return critique_next_steps(named, bool(misfit), float(error), [n for n in negligible if isinstance(n, str)] if isinstance(negligible, list) else ())


def _rivals(page: Page, critique: CritiqueFindings, source: str) -> None:
    """The candidates each named cause ties with, is contested by, or explains, in words, with the plan that separates
    a pair of physical candidates (as ``bayescal critique`` prints them)."""
    from bayescal.critique.document import explains_sentence, separating_plan
    from bayescal.critique.extensions import PLANNABLE

    meaning = {
        "tied_with": "this campaign cannot tell them apart: their fitted deflections differ nowhere by a reading's noise",
        "contested_by": "its held-out lead over them is within two standard errors, though some reading of this plan could separate them",
    }
    found = critique.to_json()
    for key in ("tied_with", "contested_by", "explains"):
        if found.get(key):
            page.record(key, found[key])
    for key, words in meaning.items():
        pairs = found.get(key)
        if not isinstance(pairs, Mapping):
            continue
        for cause, others in pairs.items():
            if not (isinstance(others, list) and others and all(isinstance(o, str) for o in others)):
                generic(page, {key: {cause: others}})
                continue
            separable = [o for o in others if {cause, o} <= set(PLANNABLE)]
            plans = "; ".join(separating_plan(cause, o, source) for o in separable)
            page.paragraph(f"{cause} is {key.replace('_', ' ')} {', '.join(others)}: {words}." + (f" The experiment that separates them: {plans}." if plans else ""))
    explains = found.get("explains")
    if isinstance(explains, Mapping):
        for cause, rivals in explains.items():
            for rival, comparisons in (rivals.items() if isinstance(rivals, Mapping) else ()):
                try:
                    added, back = (comparisons[k] for k in ("rival_added", "cause_added"))
                    page.paragraph(explains_sentence(cause, rival, (added["delta_elpd"], added["se"]), (back["delta_elpd"], back["se"])) + ".")
                except (KeyError, TypeError, ValueError):
                    generic(page, {"explains": {cause: {rival: comparisons}}})


def _shared_by_state(page: Page, critique: CritiqueFindings) -> None:
    """The heavy tails not named as gross tracker errors because every marker of a state shares them, in words."""
    from bayescal.critique.document import shared_by_state_sentence

    shared = critique.to_json().get("shared_by_state")
    if not shared:
        return
    page.record("shared_by_state", shared)
    for name, comparison in (shared.items() if isinstance(shared, Mapping) else ()):
        try:
            page.paragraph(shared_by_state_sentence(name, comparison["delta_elpd"], comparison["se"]))
        except (KeyError, TypeError, ValueError):
            generic(page, {"shared_by_state": {name: comparison}})


def _by_repeats(page: Page, critique: CritiqueFindings) -> None:
    """The cause named because it accounts for the misfit the repeats reveal, in words (as ``bayescal critique`` says it)."""
    from bayescal.critique.document import by_repeats_sentence

    named = critique.to_json().get("by_repeats")
    if not named:
        return
    page.record("by_repeats", named)
    evidence = critique.evidence
    for name, entry in (named.items() if isinstance(named, Mapping) else ()):
        try:
            page.paragraph(by_repeats_sentence(name, evidence[name]["delta_elpd"], evidence[name]["se"],
                                               entry["lack_of_fit"]["p_value"], entry["lack_of_fit_with_it"]["p_value"]) + ".")
        except (KeyError, TypeError, ValueError):
            generic(page, {"by_repeats": {name: entry}})


def _elpd_frame(rows: Mapping, extra: tuple[str, ...]) -> pd.DataFrame:
    """ΔELPD, SE and ``extra`` of each row of the critique's JSON, under its keys (the page shows them in words)."""
    frame = pd.DataFrame.from_dict(
        {name: {key: row.get(key, math.nan) for key in ("delta_elpd", "se")} | {key: row.get(key) for key in extra} for name, row in rows.items()},
        orient="index",
    )
    return frame.astype({"delta_elpd": float, "se": float})


def _elpd_table(page: Page, key: str, frame: pd.DataFrame, caption: str) -> None:
    page.table(key, frame, shown=table_texts(frame, {}, {"delta_elpd": fixed(1), "se": fixed(1)}), caption=caption, words=label)


def _evidence(page: Page, evidence) -> None:
    if not (isinstance(evidence, Mapping) and evidence and all(isinstance(v, Mapping) for v in evidence.values())):
        if evidence is not None:
            generic(page, {"evidence": evidence})
        return
    frame = _elpd_frame(evidence, ("step", "named"))
    frame.index.name = "candidate"
    held_out = {row.get("n_configs") for row in evidence.values()} - {None}
    _elpd_table(
        page,
        "evidence",
        frame,
        "Held-out gain of each candidate effect over the calibrated model"
        + (f" ({held_out.pop()} configurations held out one at a time)" if len(held_out) == 1 else ""),
    )
    usable = [name for name, row in evidence.items() if finite_number(row.get("delta_elpd")) and finite_number(row.get("se"))]
    if usable:
        page.figure(
            "critique_evidence",
            plot_evidence(usable, [evidence[n]["delta_elpd"] for n in usable], [evidence[n]["se"] for n in usable]),
            "ΔELPD of each candidate effect over the calibrated model, ±2 SE.",
        )


def _lack_of_fit(page: Page, lack) -> None:
    if not isinstance(lack, Mapping):
        return
    page.record("lack_of_fit", lack)
    if not all(finite_number(lack.get(key)) for key in ("factor", "statistic", "p_value")):
        return
    level = lack.get("level", 0.01)
    dof = lack.get("dof", ["?", "?"])
    page.paragraph(
        f"Lack of fit against the repeats: the configuration means scatter {lack['factor']:.2f} times as much about the "
        f"model as the repeats allow (F = {lack['statistic']:.2f} on {dof[0]} and {dof[1]} degrees of freedom, "
        f"p = {lack['p_value']:.2g}); " + ("the model misses an effect." if lack["p_value"] < level else f"consistent with the repeats (p ≥ {level:g}).")
    )


def _gain(page: Page, gain) -> None:
    if not isinstance(gain, Mapping):
        return
    page.record("gain", gain)
    before, after = gain.get("before"), gain.get("after")
    if not (finite_number(gain.get("delta_elpd")) and isinstance(before, Mapping) and isinstance(after, Mapping)):
        generic(page, {"gain": gain})
        return
    words = [f"Held-out gain of the final model over the classical one: ΔELPD {gain['delta_elpd']:.1f} ± {gain.get('se', math.nan):.1f} nats"]
    for key, what in (("residual_rms_mm", "residual rms"), ("position_error_rms_mm", "position error rms")):
        if finite_number(before.get(key)) and finite_number(after.get(key)):
            words.append(f"{what} {before[key] * 1000:.1f} → {after[key] * 1000:.1f} μm")
    test_pose = gain.get("test_pose")
    if isinstance(test_pose, Mapping) and finite_number(test_pose.get("classical_error_mm")):
        words.append(f"at the test pose the classical prediction lies {test_pose['classical_error_mm'] * 1000:.1f} μm from the extended one's")
    page.paragraph("; ".join(words) + ".")


def registration_section(page: Page, registration: RegistrationFindings, source: str) -> None:
    """The tracker's registration as ``bayescal axes -o`` wrote it: axes, frames with their sd, arc residuals.

    Every coordinate is rounded to its own sd (:mod:`bayescal.numbers`): an axis point about 2 m
    from the tracker, known to 0.2 mm, reads ``-1850.88``, not four significant digits' ``-1851``.
    """
    page.heading("registration", "Tracker registration")
    page.paragraph(
        f"{'From ' + source + ': t' if source else 'T'}he joint axes fitted from sweeps in the tracker frame, and the robot's "
        "frames built from axes 1 and 2 (p_tracker = R p + t); a campaign or arcs given with this registration were "
        "moved into these frames, the rotation's uncertainty added to each reading (docs/registration.md)."
    )
    axes = {str(joint): axis for joint, axis in registration.axes.items() if isinstance(axis, Mapping)}
    if axes:
        frame, shown = _axes_table(axes)
        page.table("axes", frame, shown=shown, caption="Joint axes in the tracker frame: unit direction and the point nearest the tracker's origin")
    frames = {str(name): entry for name, entry in registration.frames.items() if isinstance(entry, Mapping)}
    for joint, why in (registration.left_out or {}).items():
        page.paragraph(f"joint {joint}: no axis: the sweep {why}.")
    if registration.missing:
        page.paragraph(f"{registration.missing}.")
    for name, entry in frames.items():
        if entry.get("from_nominal"):
            page.paragraph(f"{name} frame: {entry['from_nominal']}.")
    if frames:
        frame, shown = _frames_table(frames)
        page.table("frames", frame, shown=shown, caption="The robot's frames in the tracker frame: R as a rotation vector, t, and their sd")
    rows = [{"joint": joint, **reflector} for joint, axis in axes.items() for reflector in axis.get("reflectors", []) if isinstance(reflector, Mapping)]
    if rows:
        frame = pd.DataFrame(rows)
        frame.index = pd.Index([f"{row['joint']} {row.get('marker', '')}" for row in rows], name="joint, reflector")
        frame = frame.drop(columns=["joint"])
        # Lengths and angles to 1 μm and 0.001°, the standardised rms to 0.01: no sd of their own in the file.
        formats = {c: fixed(2 if c == "z_rms" else 3) for c in frame.columns if c.endswith(("_mm", "_deg")) or c == "z_rms"}
        page.table("reflectors", frame, shown=table_texts(frame, {}, formats), words=label,
                   caption="Arc residuals per reflector (z_rms: rms standardised residual, about 1 when the tracker model holds)")
    critique = registration.critique
    if isinstance(critique, Mapping):
        page.paragraph(f"Sweep critique (held out one angle at a time): {critique.get('verdict', '–')}", css="verdict")
        evidence = {f"{joint} {name}": row for joint, entry in critique.get("joints", {}).items() if isinstance(entry, Mapping)
                    for name, row in entry.get("evidence", {}).items() if isinstance(row, Mapping)}
        if evidence:
            frame = pd.DataFrame.from_dict(evidence, orient="index")
            frame.index.name = "joint, candidate"
            rounded = {"estimate": "estimate_sd", "estimate_sd": "estimate_sd"} if {"estimate", "estimate_sd"} <= set(frame.columns) else {}
            formats = {c: fixed(1) if c in ("delta_elpd", "se") else fixed(4) for c in frame.columns if c in ("delta_elpd", "se") or c.endswith("_mm")}
            page.table("sweep_critique", frame, shown=table_texts(frame, rounded, formats), words=label,
                       caption="Held-out gain (ΔELPD, nats) of each candidate over the circle model")
    page.close()


def _axes_table(axes: Mapping[str, Mapping]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The axes' numbers and their texts: directions to their sd, points to theirs, arc rms to 1 μm, χ²/dof to 0.01."""
    numbers, texts = {}, {}
    for joint, axis in axes.items():
        direction_sd = _number(axis.get("direction_sd_mrad")) * 1e-3
        point_sd = _number(axis.get("point_sd_mm"))
        chi2 = axis["chi2"] / axis["dof"] if finite_number(axis.get("chi2")) and axis.get("dof") else None
        half = axis.get("half_width") if isinstance(axis.get("half_width"), Mapping) else {}
        row = {
            **{f"a{c}": (v, direction_sd) for c, v in zip("xyz", axis.get("direction", []))},
            "direction sd (mrad)": (axis.get("direction_sd_mrad"), _number(axis.get("direction_sd_mrad"))),
            **{f"{c} (mm)": (v, point_sd) for c, v in zip("xyz", axis.get("point_mm", []))},
            "point sd (mm)": (axis.get("point_sd_mm"), point_sd),
            # The half-widths of the Student-t intervals covering as the normal's ±3 sd, to their sd's digits (a
            # file written before they were has none).
            **({"direction ±3σ (mrad)": (half.get("direction_mrad", {}).get("3"), _number(axis.get("direction_sd_mrad"))),
                "point ±3σ (mm)": (half.get("point_mm", {}).get("3"), point_sd),
                "dof": (_smaller(axis.get("direction_dof"), axis.get("point_dof")), fixed(1))} if half else {}),
            "arc rms (mm)": (axis.get("rms_mm"), fixed(3)),
            "χ²/dof": (chi2, fixed(2)),
        }
        numbers[joint] = {key: value for key, (value, _) in row.items()}
        texts[joint] = {key: _text(value, how, sd_column=" sd " in key) for key, (value, how) in row.items()}
    return _framed(numbers, "joint"), _framed(texts, "joint")


def _frames_table(frames: Mapping[str, Mapping]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The frames' rotation vectors (deg) and translations (mm), each to its own sd, and the sd to two digits."""
    from scipy.spatial.transform import Rotation

    numbers, texts = {}, {}
    for name, entry in frames.items():
        rotation = np.asarray(entry.get("rotation", np.eye(3)), dtype=float)
        rotation_sd = [_number(v) for v in entry.get("rotation_sd_mrad", [])]
        translation_sd = [_number(v) for v in entry.get("translation_sd_mm", [])]
        row = {
            **{f"rotation vector {c} (deg)": (v, np.degrees(sd * 1e-3)) for c, v, sd in
               zip("xyz", np.degrees(Rotation.from_matrix(rotation).as_rotvec()), rotation_sd or [math.nan] * 3)},
            **{f"rotation sd {c} (mrad)": (v, v) for c, v in zip("xyz", rotation_sd)},
            **{f"t{c} (mm)": (v, sd) for c, v, sd in zip("xyz", entry.get("translation_mm", []), translation_sd or [math.nan] * 3)},
            **{f"t{c} sd (mm)": (v, v) for c, v in zip("xyz", translation_sd)},
        }
        numbers[name] = {key: value for key, (value, _) in row.items()}
        texts[name] = {key: _text(value, sd, sd_column=" sd " in key) for key, (value, sd) in row.items()}
    return _framed(numbers, "frame"), _framed(texts, "frame")


def _number(value) -> float:
    return float(value) if finite_number(value) else math.nan


def _smaller(*dofs) -> float | None:
    """The smaller of an axis's degrees of freedom (null in its file: a normal's, infinite); None when it has none."""
    known = [v for v in dofs if finite_number(v)]
    return min(known) if known else None


def _text(value, how, *, sd_column: bool) -> str:
    """``value`` rounded to the sd ``how`` (the sd itself to two digits when ``sd_column``), or by the formatter ``how``."""
    if not finite_number(value):
        return "–"
    if callable(how):
        return how(float(value))
    return rounded_pair(float(value), how)[1 if sd_column else 0]


def _framed(rows: Mapping[str, Mapping], index: str) -> pd.DataFrame:
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame.index.name = index
    return frame
