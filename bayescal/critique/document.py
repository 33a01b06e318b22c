"""The critiques' documents (:class:`~bayescal.summary.Summary`): what ``bayescal critique`` prints, in one place.

:func:`critique_document` lays out a :class:`~bayescal.critique.results.CritiqueResults`,
:func:`geometry_critique_document` a :class:`~bayescal.critique.geometry.GeometryCritiqueResults`; both share the
verdict and the evidence table (:func:`_outcome`).  They read the results' fields and say them; every verdict and
number was decided by the critique.
"""

from __future__ import annotations

from collections.abc import Sequence

from bayescal.summary import Column, Paragraph, Section, Summary, Table

__all__ = ["critique_document", "geometry_critique_document", "separating_plan", "shared_by_state_sentence", "explains_sentence",
           "by_repeats_clause", "by_repeats_sentence"]


def _evidence_table(evidence: dict) -> Table:
    """Each candidate's held-out ΔELPD and SE (nats) at its step, and whether it was named."""
    width = max(len("candidate"), *map(len, evidence)) + 2
    columns = (
        Column("candidate", width=width, align="<"),
        Column("step", width=5),
        Column("ΔELPD", "nats", width=10),
        Column("SE", "nats", width=8),
        Column("named", align="<", before="  "),
    )
    rows = tuple(
        (name, str(entry["step"]), f"{entry['delta_elpd']:.1f}", f"{entry['se']:.1f}", "yes" if entry["named"] else "")
        for name, entry in evidence.items()
    )
    values = tuple(
        {"candidate": name, "step": entry["step"], "ΔELPD": entry["delta_elpd"], "SE": entry["se"], "named": entry["named"]}
        for name, entry in evidence.items()
    )
    return Table("evidence", columns, rows, values)


def _outcome(results, held_out: str, baseline: str) -> tuple[Paragraph, list[Paragraph | Table]]:
    """The verdict, and every candidate's evidence with the unexplained covariate, for either critique."""
    if results.verdict == "adequate":
        verdict = f"verdict: adequate - no extension predicts held-out {held_out} clearly better than {baseline}"
    else:
        verdict = f"verdict: misfit - causes in order of gain: {', '.join(results.causes)}"
    negligible = getattr(results, "negligible", [])
    if negligible:
        verdict += f" ({', '.join(negligible)} detectable but too small to matter at the test pose)"
    blocks: list[Paragraph | Table] = [
        _evidence_table(results.to_json()["evidence"]),
        Paragraph(f"(ΔELPD: held-out log predictive density gained over {baseline}, in nats; SE: its standard error; docs/glossary.md)",
                  kind="note"),
    ]
    if results.unexplained_covariate is not None:
        c = results.probes[results.unexplained_covariate]
        blocks.append(Paragraph(
            f"unexplained: the residuals follow {results.unexplained_covariate} (ΔELPD {c.delta_elpd:.1f} ± {c.se:.1f} nats) "
            "and no extension of the catalogue explains it", kind="warning"))
    misfit = getattr(results, "lack_of_fit", None)
    if misfit is not None:
        said = "misses them" if misfit.significant() else "fits them within the repeats' scatter"
        blocks.append(Paragraph(f"repeats: the final model {said}: {misfit.describe()}"))
        if misfit.significant() and results.unexplained_covariate is None:
            blocks.append(Paragraph("unexplained: a misfit the repeats reveal and no candidate of the catalogue matches in shape", kind="warning"))
    return Paragraph(verdict), blocks


def geometry_critique_document(results) -> Summary:
    """What the compensator-geometry critique found: verdict, evidence, held-out gain and the rule."""
    before, after = results.before, results.after
    verdict, evidence = _outcome(results, "angles", "the two-step model")
    findings = [
        f"held-out gain: ΔELPD {results.gain.delta_elpd:.1f} ± {results.gain.se:.1f} nats over {results.n_angles} angles; "
        f"residual rms per coordinate: lever {before['residual_rms_lever_mm']:.3f} -> {after['residual_rms_lever_mm']:.3f} mm, "
        f"cylinder {before['residual_rms_cylinder_mm']:.3f} -> {after['residual_rms_cylinder_mm']:.3f} mm",
        # the relative sd of a variance estimated from n - 1 degrees of freedom, sqrt(1 / (2 (n - 1)))
        f"rule: a cause is named when ΔELPD > {results.rule['z']:g} SE and > {results.rule['floor_nats']:g} nats; "
        f"with {results.n_angles} held-out angles the SE itself is uncertain by about "
        f"{100 / (2 * (results.n_angles - 1)) ** 0.5:.0f} %",
    ]
    return Summary(
        f"{results.source}: {results.n_points} points at {results.n_angles} joint angles, held out one angle at a time",
        (verdict,),
        (Section(tuple(evidence)), Section(tuple(Paragraph(line) for line in findings))),
    )


def separating_plan(cause: str, other: str, source: str) -> str:
    """The command that designs the experiment separating two physical candidates on the campaign ``source``
    (docs/critique.md, *The experiment that resolves a tie*)."""
    return f"bayescal plan --config CELL.toml --criterion discriminate --between {cause},{other} --campaign {source or 'CAMPAIGN.csv'} -o PLAN.csv"


def shared_by_state_sentence(name: str, delta_elpd: float, se: float) -> str:
    """Why a heavy tail was not named as gross tracker errors: every marker of a state shares it better by ``delta_elpd``
    ± ``se`` nats held out."""
    return (f"{name} not named: its heavy tail is shared by every marker of a state, {delta_elpd:.1f} ± {se:.1f} nats better "
            "per state than per reading. The arm is off in those states, not the tracker's readings.")


def explains_sentence(cause: str, rival: str, rival_added: tuple[float, float], cause_added: tuple[float, float]) -> str:
    """Why ``rival`` does not contest ``cause``: the held-out gain (nats, its SE) of the rival added on top of the cause
    and of the cause added on top of the rival (:func:`~bayescal.critique.rule.explains`)."""
    return (f"{cause} explains {rival}: {rival} adds {rival_added[0]:.1f} ± {rival_added[1]:.1f} nats on top of it, "
            f"{cause} {cause_added[0]:.1f} ± {cause_added[1]:.1f} on top of {rival}, so {rival} does not contest it")


def by_repeats_clause(z: float, floor_nats: float) -> str:
    """The rule's clause for a cause the repeats name (:func:`~bayescal.critique.rule.accounts_for`), as the rule's
    sentence ends in the text and the review."""
    return f"; where the repeats show a misfit no cause passes for, > {z:g} SE and > {floor_nats:g} nats if the repeats are then fitted"


def by_repeats_sentence(name: str, delta_elpd: float, se: float, p_without: float, p_with: float) -> str:
    """Why ``name`` was named below the rule: it accounts for the misfit the repeats reveal
    (:func:`~bayescal.critique.rule.accounts_for`)."""
    return (f"{name} named by the repeats: without it the model misses them (lack of fit p = {p_without:.2g}), with it "
            f"they are fitted (p = {p_with:.2g}); its held-out gain, {delta_elpd:.1f} ± {se:.1f} nats, is clear of one "
            "standard error, not of the rule")


def _importance_lines(results) -> list[str]:
    """What each named cause changes, then the candidates it ties with or is contested by, the plan that separates them,
    and the rivals it explains."""
    from bayescal.critique.extensions import PLANNABLE

    lines = []
    for cause, entry in results.importance.items():
        before, after = (1000 * v for v in entry["residual_rms_mm"])
        lines.append(
            f"{cause}: residual rms {before:.1f} -> {after:.1f} μm, test pose moved {1000 * entry['test_pose_change_mm']:.1f} μm "
            f"(its sd {1000 * entry['test_pose_sd_mm']:.1f} μm)"
            + ("" if entry["matters"] else ": detectable but too small to matter")
        )
    for kind, pairs in (("tied with", results.tied_with), ("contested by", results.contested_by)):
        for cause, others in pairs.items():
            lines.append(f"{cause} {kind} {', '.join(others)}")
            # the plan that separates exactly that pair (docs/critique.md, The experiment that resolves a tie)
            lines += [f"  to separate them: {separating_plan(cause, other, results.source)}" for other in others if {cause, other} <= set(PLANNABLE)]
    for cause, others in results.explains.items():
        for other, (rival_added, cause_added) in others.items():
            lines.append(explains_sentence(cause, other, (rival_added.delta_elpd, rival_added.se), (cause_added.delta_elpd, cause_added.se)))
    lines += [shared_by_state_sentence(name, per_state.delta_elpd, per_state.se) for name, per_state in results.shared_by_state.items()]
    evidence = results.evidence
    lines += [by_repeats_sentence(name, evidence[name].delta_elpd, evidence[name].se, without.p_value, with_it.p_value)
              for name, (without, with_it) in results.by_repeats.items()]
    return lines


def _drift_lines(results) -> list[str]:
    """The drift measured and removed (nests, repeats or both), or the one the repeated readings show, or why they cannot."""
    from bayescal.registration.nest_drift import removed_drift_sentence

    drift = results.drift
    if "source" in drift:
        return [removed_drift_sentence(drift)]
    if drift.get("testable") and "speed_mm_per_h" not in drift:
        return [f"drift: not tried (left out of the catalogue); the campaign could show one: {drift['evidence']}"]
    if drift.get("testable"):
        return [
            f"drift from {drift['evidence']}: {drift['speed_mm_per_h']:.3f} ± {drift['speed_sd_mm_per_h']:.3f} mm/h, "
            f"{1000 * drift['deflection_rms_mm']:.1f} μm rms in the deflections"
            + (" (removed)" if "drift" in results.causes else "")
        ]
    return [f"drift: not testable on this campaign: {drift['evidence']}"] if drift else []


def critique_document(results, figures: Sequence[str] = ()) -> Summary:
    """What the campaign critique found: verdict, evidence, held-out gain, what each cause changes, drift, next step.

    ``figures``: the files the figures were written to, named in the document when given.
    """
    from bayescal.inference.next_steps import critique_next_steps

    before, after = results.before, results.after
    verdict, evidence = _outcome(results, "configurations", "the classical model")
    findings = [
        f"held-out gain: ΔELPD {results.gain.delta_elpd:.1f} ± {results.gain.se:.1f} nats; residual rms "
        f"{before['residual_rms_mm'] * 1000:.1f} -> {after['residual_rms_mm'] * 1000:.1f} μm; position error rms "
        f"{before['position_error_rms_mm'] * 1000:.1f} -> {after['position_error_rms_mm'] * 1000:.1f} μm",
        f"test pose: the classical model's prediction differs from the extended one's by "
        f"{results.test_pose['classical_error_mm'] * 1000:.1f} μm",
        f"rule: a cause is named when ΔELPD > {results.rule['z']:g} SE and > {results.rule['floor_nats']:g} nats, "
        f"or > {results.rule['decisive_nats']:g} nats and > {results.rule['decisive_z']:g} SE"
        + by_repeats_clause(results.rule["decisive_z"], results.rule["floor_nats"]),
        *_importance_lines(results),
        *_drift_lines(results),
        *([f"figures: {', '.join(figures)}"] if figures else []),
    ]
    misfit = results.lack_of_fit
    advice = critique_next_steps(
        list(results.causes), misfit is not None and misfit.significant(), results.test_pose["classical_error_mm"], results.negligible
    )
    return Summary(
        f"{results.source}: {results.n_equations} equations in {results.n_configs} configurations",
        (verdict,),
        (Section(tuple(evidence)), Section(tuple(Paragraph(line) for line in findings)), Section((Paragraph(advice, wrap=True),))),
    )
