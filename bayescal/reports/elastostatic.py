"""The elastostatic identification report: a Table III campaign on the twin, identified and judged.

``python -m bayescal.reports.elastostatic [--config data/kr270.toml] [--plan data/table3_plan.csv]
[--seed 1] [-o reports/elastostatic.md]`` simulates the campaign, identifies it with the exact and
the linear model, checks the truth against the ±3σ intervals, sets the relative widths beside
Klimchik et al.'s Table IV, works out what precision Table IV's compensator intervals would need,
measures the linear model's misfit (χ²/dof) at a fixed 8 μm tracker noise with full and tenfold
reduced loads, measures how much the exact model's correction depends on the assumed link masses
and compensator spring, and carries the posterior to the test pose.
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.cell.config import Cell, load_cell
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import scale_masses
from bayescal.inference.results import ElastostaticResults
from bayescal.inference.identifiability import grouped
from bayescal.cell.plan import Plan, read_plan
from bayescal.reports.plots import plot_joint2_compliance
from bayescal.robot.stiffness import ElasticArm
from bayescal.reference import published
from bayescal.inference.testpose import predict_cell_test_pose
from bayescal.cell.tracker import TrackerNoise
from bayescal.twin.simulator import DigitalTwin
from bayescal.tables import markdown_table
from bayescal.units import DEG, MM, N_PER_MM, UM, URAD_PER_NM

__all__ = ["build_report", "compensator_precision", "linearisation_misfit", "weightless", "main"]

NAMES = ["k1", "k2", "k3", "k4", "k5", "k6", "K_c", "s0"]


def _truth(cell: Cell) -> dict[str, float]:
    values = {f"k{j + 1}": cell.compliances[j] / URAD_PER_NM for j in range(6)}
    values["K_c"] = cell.compensator.K_c / N_PER_MM
    values["s0"] = cell.compensator.s0 / MM
    return values


def _table(frame: pd.DataFrame, digits: int = 4) -> str:
    rows = [
        [name, *(f"{v:.{digits}g}" if isinstance(v, float | np.floating) else v for v in row)] for name, row in frame.iterrows()
    ]
    return markdown_table([frame.index.name or "", *frame.columns], rows)


def _closed_form_shift(model: ElastostaticModel, campaign, reference, sd) -> dict[str, float]:
    cf, _ = model.estimate(campaign)
    values = {f"k{j + 1}": cf.compliances[j] / URAD_PER_NM for j in range(6)}
    if cf.spring is not None:
        values |= {"K_c": cf.spring[1] / N_PER_MM, "s0": cf.spring[2] / MM}
    return {name: (values[name] - reference[name]) / sd[name] for name in sd if np.isfinite(values.get(name, np.nan))}


def linearisation_misfit(cell: Cell, plan: Plan, noise: float, *, load_scale: float = 1.0, seed: int = 0, repeats: int = 3) -> dict:
    """χ²/dof of the linear and the exact model on one twin campaign with a fixed tracker noise.

    The twin measures ``plan`` with its loads multiplied by ``load_scale`` and a
    tracker whose error is ``noise`` (m) on every coordinate, whatever the
    distance.  Both models fit the same campaign in closed form; χ² is over the
    campaign's deflection equations (3 per row, each the difference of two
    readings, so of variance ``2 noise²``) with ``n - p`` degrees of freedom for
    ``p`` per-angle compliances.

    Returns
    -------
    dict
        ``linear``, ``exact`` (χ²/dof), ``n_equations``, ``dof``, ``noise_um``, ``load_scale``, ``seed``.
    """
    tracker = TrackerNoise(cell.tracker.position, U0=noise, U1=0.0, factor=1.0)
    fixed = dataclasses.replace(cell, tracker=tracker)
    scaled = dataclasses.replace(plan, load_kg=plan.masses(cell.load_mass) * load_scale)
    campaign = DigitalTwin(fixed).simulate(scaled, repeats, np.random.default_rng(seed))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        linear = ElastostaticModel.from_cell(fixed, model="linear")
        chi2 = {name: ElastostaticModel.from_cell(fixed, model=name).chi2_per_dof(campaign) for name in ("linear", "exact")}
        _, ident = linear.estimate(campaign)
    n = 3 * len(campaign)
    return chi2 | {
        "n_equations": n,
        "dof": n - int(ident.identifiable.sum()),
        "noise_um": noise / UM,
        "load_scale": load_scale,
        "seed": seed,
    }


def weightless(cell: Cell) -> Cell:
    """The cell with massless links and a compensator spring of zero stiffness: the unloaded arm does not sag."""
    spring = cell.compensator.geometry.with_spring(0.0, cell.compensator.s0)
    return dataclasses.replace(cell, robot=scale_masses(cell.robot, 0.0), compensator=spring)


def compensator_precision(results: ElastostaticResults, cell: Cell) -> dict:
    """What the per-angle joint-2 compliances give for K_c and s0 through eq 34, and what Table IV's widths would need.

    The covariance of the per-angle compliances (eq 37, from the closed form)
    is carried to ``[K_theta2^0, K_c, s0 K_c]`` through the least squares of
    eq 34 at the cell's spring, then to ``s0``; the relative ±3σ widths are
    compared with Table IV's.  The required improvement of the per-angle
    compliances is the ratio of the widths (they scale together with the noise).

    Returns
    -------
    dict
        ``share_pct`` (min, max) of the compensator in the joint-2 stiffness over the campaign's
        angles; ``per_angle_3sd_pct`` (median relative ±3σ of the per-angle compliances);
        ``width_pct`` and ``needed_factor`` for ``K_c`` and ``s0``; ``needed_per_angle_3sd_pct``.
    """
    cf = results.closed_form
    ident = results.identifiability
    kept = [name for name, keep in zip(ident.names, ident.identifiable) if keep]
    joint2 = [name for name in ident.names if name.startswith("k2_q2[")]
    index = [i for i, name in enumerate(kept) if name in joint2]
    angles = [joint2.index(kept[i]) for i in index]
    k2 = cf.per_angle[index]
    cov_k = cf.cov[np.ix_(index, index)]
    # Stiffness K = 1/k: its covariance by the delta method.
    jacobian = np.diag(-1.0 / k2**2)
    cov_K = jacobian @ cov_k @ jacobian.T
    compensator = cell.compensator
    C = CompensatorGeometry(*results.geometry.mean).regressor(results.q2[angles])
    projection = np.linalg.pinv(C)
    cov_w = projection @ cov_K @ projection.T
    Kc, s0 = compensator.K_c, compensator.s0
    w = np.array([1.0 / cell.compliances[COMPENSATED_JOINT], Kc, s0 * Kc])
    gradient_s0 = np.array([0.0, -w[2] / w[1] ** 2, 1.0 / w[1]])
    width = {
        "K_c": 300.0 * np.sqrt(cov_w[1, 1]) / Kc,
        "s0": 300.0 * np.sqrt(gradient_s0 @ cov_w @ gradient_s0) / s0,
    }
    table_iv = published("IV")
    factor = {name: width[name] / table_iv[name][1] * table_iv[name][0] / 100.0 for name in width}
    per_angle = float(np.median(300.0 * np.sqrt(np.diag(cov_k)) / k2))
    share = 100.0 * np.abs(compensator.stiffness(results.q2[angles])) * cell.compliances[COMPENSATED_JOINT]
    return {
        "share_pct": (float(share.min()), float(share.max())),
        "per_angle_3sd_pct": per_angle,
        "width_pct": width,
        "needed_factor": factor,
        "needed_per_angle_3sd_pct": per_angle / max(factor.values()),
    }


def _balance(cell: Cell, factor: float) -> dict[str, float]:
    """How well a spring ``factor`` times as stiff as the cell's, with its best free length, balances the arm's weight.

    Over q2 from -140° to 0° with the forearm horizontal (q3 = -q2): the
    joint-2 torque of the links' weight against the compensator's ``-M_c``.

    Returns
    -------
    dict
        ``s0`` (m), the free length of least rms residual; ``residual_rms`` (N·m);
        ``weight_max`` (N·m), the largest joint-2 torque of the weight alone.
    """
    comp = cell.compensator
    q2 = np.linspace(-140.0, 0.0, 57) * DEG
    gravity = []
    for angle in q2:
        q = np.zeros(cell.robot.nq)
        q[1], q[2] = angle, -angle
        gravity.append(cell.robot.gravity_torque(q)[1])
    gravity = np.array(gravity)
    Kc = factor * comp.K_c
    lever = comp.a * comp.L * np.sin(comp.gamma(q2))
    # M_c = Kc lever (1 - s0 / s) (eq 7) must cancel the drive torque g2; it is linear in s0.
    column = -Kc * lever / comp.s(q2)
    target = -gravity - Kc * lever
    s0 = float(column @ target / (column @ column))
    residual = target - column * s0
    return {"s0": s0, "residual_rms": float(np.sqrt(np.mean(residual**2))), "weight_max": float(np.abs(gravity).max())}


def build_report(
    config: str = "data/kr270.toml", plan_path: str = "data/table3_plan.csv", seed: int = 1, figure: Path | None = None
) -> str:
    """The Markdown report for the twin's campaign of ``plan_path`` with ``seed``.

    With ``figure``, the equivalent joint-2 compliance against q2 (the paper's
    Fig. 7) is drawn to that PNG file and shown in the report.
    """
    cell = load_cell(config)
    plan = read_plan(plan_path, cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(seed))
    truth = _truth(cell)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = ElastostaticModel.from_cell(cell)
        results = model.fit(campaign, seed)
    messages = sorted({str(w.message) for w in caught})
    with warnings.catch_warnings():
        # The linear fit of the same campaign repeats those warnings with its own numbers.
        warnings.simplefilter("ignore")
        linear = ElastostaticModel.from_cell(cell, model="linear").fit(campaign, seed)
    parameters = results.parameters()
    summary = results.summary()
    practical = results.identifiability.practical

    rows = {}
    for name in NAMES:
        entry = parameters[name]
        paper = published("IV").get(name)
        paper_cells = [paper[0], paper[1], f"{100 * paper[1] / paper[0]:.1f}%"] if paper else ["–", "–", "–"]
        if "mean" not in entry:
            rows[name] = [results.parameter_units[name], "not identifiable", "", "", truth[name], "", *paper_cells]
            continue
        width = 100 * 3 * entry["sd"] / abs(entry["mean"])
        inside = entry["lo3"] <= truth[name] <= entry["hi3"]
        rows[name] = [entry["unit"], entry["mean"], 3 * entry["sd"], f"{width:.1f}%", truth[name], "yes" if inside else "NO", *paper_cells]
    estimates = pd.DataFrame.from_dict(
        rows,
        orient="index",
        columns=["unit", "mean", "±3σ", "width", "truth", "truth inside", "Table IV", "Table IV ±3σ", "Table IV width"],
    )
    estimates.index.name = "parameter"

    comparison = results.linear_vs_exact()
    comparison = comparison.loc[[n for n in comparison.index if n in NAMES or n.startswith("k2_q2")], ["shift_in_sd", "sd_ratio"]]
    sampled = [name for name in NAMES if name in summary.index]
    sd = {name: summary.loc[name, "sd"] for name in sampled}
    means = {name: summary.loc[name, "mean"] for name in sampled}
    truth_shift = {name: (truth[name] - means[name]) / sd[name] for name in sampled}

    sensitivity = {}
    with warnings.catch_warnings():
        # The campaign's warnings were recorded by the fit above.
        warnings.simplefilter("ignore")
        base = _closed_form_shift(model, campaign, means, sd)
        for label, changed in (
            ("link masses ×0.8", dataclasses.replace(model, robot=scale_masses(cell.robot, 0.8))),
            ("link masses ×1.2", dataclasses.replace(model, robot=scale_masses(cell.robot, 1.2))),
            ("nominal K_c ×0.8", dataclasses.replace(model, nominal_spring=(0.8 * cell.compensator.K_c, cell.compensator.s0))),
            ("nominal K_c ×1.2", dataclasses.replace(model, nominal_spring=(1.2 * cell.compensator.K_c, cell.compensator.s0))),
        ):
            shifted = _closed_form_shift(changed, campaign, means, sd)
            sensitivity[label] = {name: shifted[name] - base[name] for name in shifted}
    sensitivity_frame = pd.DataFrame(sensitivity)
    sensitivity_frame.index.name = "parameter"

    test_pose = predict_cell_test_pose(results, cell)
    arm = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, load_point=cell.test_point)
    loaded = cell.test_q + arm.equilibrium(cell.test_q, cell.test_wrench)
    unloaded = cell.test_q + arm.equilibrium(cell.test_q, np.zeros(6))
    true_deflection = cell.robot.point_position(loaded, cell.test_point) - cell.robot.point_position(unloaded, cell.test_point)
    against_truth = dataclasses.replace(test_pose, reference=true_deflection)
    block = test_pose.to_json()
    truth_block = against_truth.to_json()["residual_error_mm"]

    d = results.diagnostics()
    dl = linear.diagnostics()
    masses = plan.masses(cell.load_mass)
    noise = np.concatenate([cell.tracker.sigma(campaign.p0), cell.tracker.sigma(campaign.p1)]) / UM
    reasons = {k: v for k, v in results.identifiability.not_identifiable.items() if k in NAMES}

    lines = [
        "# Elastostatic identification on the digital twin",
        "",
        f"Generated by `python -m bayescal.reports.elastostatic --config {config} --plan {plan_path} --seed {seed}`.",
        "",
        "## Campaign",
        "",
        f"The twin (`{config}`) measures the {len(plan)} configurations of Klimchik et al., Table III, "
        f"3 times each with 3 markers: {len(campaign)} rows, each giving the x, y and z of one marker "
        f"deflection, so {results.n_equations} scalar equations — the paper's count of 405. The loads are masses of "
        f"{masses.min():g} to {masses.max():g} kg hanging at the tool's load point; the tracker noise per coordinate is "
        f"{noise.min():.1f} to {noise.max():.1f} μm (the cell's distance-dependent model), so each deflection "
        "coordinate carries √2 times that.",
        "",
        "## Estimates beside Table IV",
        "",
        f"Exact model, {results.sampler_name}, {d['n_chains']} chains × {d['n_draws']} draws; "
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f}. "
        "Intervals are mean ± 3 sd as in the paper; widths are 3 sd / |mean|. k2 is joint 2 without its compensator. "
        "A parameter is reported only when it is identifiable both structurally (rank of the design) and from these "
        "data (rule in `docs/elastostatic.md`: the posterior sd must fall below half the prior's, or, under a flat "
        "prior on the positive half-line, the ±3σ interval must exclude 0).",
        "",
        _table(estimates),
        "",
    ]
    for names, reason in grouped(reasons):
        verb = "is" if len(names) == 1 else "are"
        kind = "not identifiable from these data" if names[0] in practical else "not identifiable"
        lines.append(f"- **{', '.join(names)} {verb} {kind}**: {reason}.")
    weak = results.weakly_determined()
    if weak:
        kept = "; ".join(
            f"{name} {entry['mean']:.4g} ± {3 * entry['sd']:.4g} {entry['unit']} "
            f"({300 * entry['sd'] / abs(entry['mean']):.0f} %, truth {truth[name]:g} "
            f"{'inside' if entry['lo3'] <= truth[name] <= entry['hi3'] else 'OUTSIDE'})"
            for name, entry in weak.items()
        )
        lines += ["", f"Their posterior is kept in the DataTree, not as an estimate: {kept}."]
    lines += [
        "",
        "Truth minus posterior mean, in posterior sd: "
        + ", ".join(f"{name} {value:+.2f}" for name, value in truth_shift.items())
        + ".",
        "",
        "Equivalent joint-2 compliance at each campaign angle (μrad/(N·m)):",
        "",
        _table(summary.loc[[n for n in summary.index if n.startswith("k2_q2")], ["mean", "sd", "lo3", "hi3"]]),
        "",
    ]
    if results.closed_form.spring is not None:
        lines += _compensator_section(results, cell, noise)
    lines += _linearisation_section(cell, plan)
    lines += [
        "## Linear against exact model on this campaign",
        "",
        f"The exact model's prediction differs from the linear one by up to {d['nonlinearity_mm'] * 1000:.1f} μm "
        f"(deflections reach {np.linalg.norm(campaign.displacement, axis=1).max() / MM:.2f} mm). "
        f"χ²/dof against the nominal tracker noise: exact {d['chi2_per_dof']:.3f}, linear {dl['chi2_per_dof']:.3f} "
        f"({results.n_equations} equations); the exact model settled after {d['relinearisations']} relinearisations. "
        "Shift of the linear model's posterior mean in exact-model sd, and ratio of the sds:",
        "",
        _table(comparison),
        "",
        "## Dependence on the assumed link masses and compensator spring",
        "",
        "The exact model's correction needs the arm's weight (the URDF's link masses, themselves an estimate) and "
        "the compensator torque that balances it (the config's spring: the deflections determine K_c too loosely). "
        "Change of the closed-form estimates, in posterior sd, when these are changed:",
        "",
        _table(sensitivity_frame),
        "",
        "## Test pose",
        "",
    ]
    if block.get("available", True):
        error = block["residual_error_mm"]
        norm = block["deflection_norm_mm"]
        lines += [
            f"Test pose q0 = {np.array2string(np.degrees(cell.test_q), precision=1)} deg under F0 = "
            f"{np.array2string(cell.test_wrench, precision=0)} (N, N·m) at the tool point "
            f"{np.array2string(cell.test_point / MM, precision=0)} mm: predicted deflection {norm['mean']:.4f} mm "
            f"± {3 * norm['sd']:.4f} mm (3σ); true deflection {np.linalg.norm(true_deflection) / MM:.4f} mm.",
            "",
            "| positioning error after compensation (mm) | rms | 95 % | 99.73 % | ρ0 from covariance (eq 38) |",
            "|---|---|---|---|---|",
            f"| spread of the posterior about its mean | {error['rms']:.4f} | {error['q95']:.4f} | {error['q99.73']:.4f} | {error['rho0_from_covariance']:.4f} |",
            f"| posterior draws against the truth | {truth_block['rms']:.4f} | {truth_block['q95']:.4f} | {truth_block['q99.73']:.4f} | |",
            "",
        ]
        for name, entry in block["assumed"].items():
            lines.append(
                f"{name}, which the campaign cannot identify, is taken from the config ({entry['value']:.3g} {entry['unit']}); "
                "its uncertainty is not in these numbers. K_c and s0 enter through their whole posterior."
            )
    else:
        lines.append(f"Not predicted: {block['reason']}.")
    if figure is not None and results.draws.spring is not None:
        lines += ["", *_joint2_figure(results, cell, figure)]
    lines += ["", "## Warnings raised by the identification", ""] + [f"- {m}" for m in messages] + [""]
    return "\n".join(lines)


def _joint2_figure(results: ElastostaticResults, cell: Cell, path: Path) -> list[str]:
    """Draw joint 2's equivalent compliance against q2 with its posterior band; the report's lines for it."""
    q2 = np.linspace(cell.robot.lower[COMPENSATED_JOINT], cell.robot.upper[COMPENSATED_JOINT], 60)
    truth = 1.0 / cell.compensator.joint_stiffness(q2, 1.0 / cell.compliances[COMPENSATED_JOINT])
    draws = results.equivalent_compliance(q2)
    closed = results.closed_form
    own = float(np.mean(1.0 / results.draws.spring[..., 0]))
    figure = plot_joint2_compliance(q2, draws, results.q2, closed.k2, closed.k2_sd, own=own, truth=truth)
    figure.savefig(path, dpi=110)
    low, median, high = np.quantile(draws, [0.00135, 0.5, 0.99865], axis=0)
    half_width = 50.0 * (high - low) / median
    swing = 100.0 * (truth.max() - truth.min()) / truth.mean()
    return [
        "## Joint 2 with its compensator (the paper's Fig. 7)",
        "",
        f"![equivalent joint-2 compliance]({path.name})",
        "",
        "The band is the posterior's 99.73 % interval of 1/(K_θ2^0 + K_c·a·L·η(q2)) (eq 8) over the joint-2 range, "
        "with every draw of the spring and the compensator geometry; the points are the per-angle estimates of eq 33 "
        "with ±3σ; the dotted line is the twin's truth and the dashed one the identified joint 2 without its "
        f"compensator (posterior mean of 1/K_θ2^0). The band's half-width is {half_width.min():.1f} to "
        f"{half_width.max():.1f} % of the compliance, while the compensator makes the true curve vary by "
        f"{swing:.2f} % over the whole range: the equivalent compliance is known to about a percent at every q2, "
        "but its variation with q2, which K_c and s0 describe, is not resolved.",
    ]


LINEARISATION_SEEDS = range(5)
"""Seeds of the twin campaigns of the linearisation study."""


def _linearisation_section(cell: Cell, plan: Plan) -> list[str]:
    cases = [
        ("the twin", cell, 1.0, 8 * UM),
        ("the twin", cell, 0.1, 0.8 * UM),
        ("without link weight and compensator", weightless(cell), 1.0, 8 * UM),
        ("without link weight and compensator", weightless(cell), 0.1, 0.8 * UM),
    ]
    rows, excess, beyond, gap = [], {}, {}, {}
    for label, twin, scale, noise in cases:
        runs = [linearisation_misfit(twin, plan, noise, load_scale=scale, seed=seed) for seed in LINEARISATION_SEEDS]
        linear = np.array([run["linear"] for run in runs])
        exact = np.array([run["exact"] for run in runs])
        dof = runs[0]["dof"]
        excess[(label, scale)] = float(np.mean(linear - exact) * dof)
        beyond[(label, scale)] = int(np.sum(linear > stats.chi2.ppf(0.999, dof) / dof))
        gap[(label, scale)] = (float(np.min(linear - exact)), float(np.max(linear - exact)))
        rows.append(
            f"| {label} | ×{scale:g} | {noise / UM:g} | {linear.mean():.3f} ({linear.min():.3f}–{linear.max():.3f}) "
            f"| {exact.mean():.3f} ({exact.min():.3f}–{exact.max():.3f}) | {excess[(label, scale)]:.1f} |"
        )
    n = runs[0]["n_equations"]
    upper = stats.chi2.ppf(0.999, dof) / dof
    arm = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, load_point=cell.load_point)
    sag = np.array([arm.equilibrium(q, np.zeros(6)) for q in plan.q])
    full = excess[("the twin", 1.0)]
    reduced = excess[("the twin", 0.1)]
    bare = excess[("without link weight and compensator", 1.0)], excess[("without link weight and compensator", 0.1)]
    return [
        "## Linearisation misfit at 8 μm tracker noise",
        "",
        "Issue 4 reports that a linear fit of a nonlinear simulation with 8 μm tracker noise leaves χ²/dof ≈ 1.3–1.4 "
        "over 810 equations, falling to 1.02 when loads and noise are both scaled down tenfold. Measured here on the "
        "Table III plan with a tracker of 8 μm per coordinate at any distance (instead of the cell's "
        "distance-dependent model), with the plan's loads, then with loads and noise ×0.1; each campaign "
        f"(seeds {LINEARISATION_SEEDS.start}–{LINEARISATION_SEEDS.stop - 1}) is fitted in closed form by the linear and the exact model. "
        "Mean (range) over the seeds; the last column is the mean excess of the linear χ² over the exact one, "
        "(χ²/dof linear − exact) × dof, which estimates the noncentrality the linearisation adds:",
        "",
        "| twin | loads | noise per coordinate (μm) | linear χ²/dof | exact χ²/dof | linear − exact χ² |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        f"χ² is over the {n} deflection equations ({n // 3} rows × 3 coordinates); each is the difference of two "
        "tracker readings and carries their summed variance 2σ², and the per-angle compliances are fitted, so "
        f"dof = {dof}. The issue's 810 counts the unloaded and the loaded readings as separate equations; with the "
        "unloaded positions as unknowns that adds as many unknowns as equations and leaves χ²/dof unchanged, so "
        f"the count does not explain a difference. Noise alone exceeds χ²/dof = {upper:.3f} with probability 0.001.",
        "",
        f"At 8 μm the linear model's misfit is real (excess χ² ≈ {full:.0f}; {beyond[('the twin', 1.0)]} of "
        f"{len(LINEARISATION_SEEDS)} seeds beyond χ²/dof = {upper:.3f}, and on every seed "
        f"{gap[('the twin', 1.0)][0]:.2f}–{gap[('the twin', 1.0)][1]:.2f} above the exact model's χ²/dof on the same data) "
        "and the exact model's χ²/dof is that of noise: the misfit is the linearisation. Our χ²/dof, about "
        f"{1 + full / dof:.2f}, is lower than the issue's 1.3–1.4; the second-order effect depends on the loads' lever "
        "arm on the tool, the joint compliances and the plan, which the issue's simulation does not state. With "
        f"loads and noise ×0.1 the linear misfit does not fall to the 1.02 of the issue but keeps an excess χ² of "
        f"about {reduced:.0f}: a part of it is proportional to the load, like the deflections and the noise, so "
        "scaling both leaves it in place. That part comes from the arm's own weight: unloaded, the arm already sags "
        f"under its links' weight and the compensator's imbalance (up to {1e3 * np.abs(sag[:, 1]).max():.2f} mrad at "
        f"joint 2 and {1e3 * np.abs(sag[:, 2]).max():.2f} mrad at joint 3 on Table III), while the linear model takes the "
        "arm at its commanded angles for its Jacobians, the load's moment arm and the markers' place on the tool. In a "
        f"twin without link weight and compensator the excess falls from {bare[0]:.0f} to {bare[1]:.1f} when loads and "
        f"noise are scaled down tenfold, a {bare[0] / bare[1]:.0f}-fold drop, near the hundredfold of a purely "
        "second-order effect (its excess χ² grows as the load squared when the noise grows with the load) — which may be the "
        "issue's situation (its simulation is not described). The exact model removes both parts.",
        "",
    ]


def _compensator_section(results: ElastostaticResults, cell: Cell, noise_um: np.ndarray) -> list[str]:
    precision = compensator_precision(results, cell)
    share_lo, share_hi = precision["share_pct"]
    per_angle = precision["per_angle_3sd_pct"]
    width, factor = precision["width_pct"], precision["needed_factor"]
    worst = max(factor.values())
    summary = results.summary()
    posterior_width = {name: 300 * summary.loc[name, "sd"] / abs(summary.loc[name, "mean"]) for name in ("K_c", "s0")}
    balance = {f: _balance(cell, f) for f in (1.0, 10.0, round(factor["K_c"]))}
    stiff = round(factor["K_c"])
    Kc = cell.compensator.K_c / N_PER_MM
    return [
        "## Why Table IV's K_c and s0 intervals are not reproduced",
        "",
        f"K_c is seen only through the compensator's share of the joint-2 stiffness, K_c·a·L·η(q2)/K_θ2^0 (eq 8): "
        f"{share_lo:.2f}–{share_hi:.2f} % at the campaign's {results.q2.size} q2 angles with the config's spring. The twin's "
        "tracker noise was set so that k2..k6 come out with Table IV's widths (`docs/twin.md`); that noise resolves the "
        f"per-angle joint-2 compliances to ±{per_angle:.2f} % (3σ, eq 37, median over the angles), "
        f"{per_angle / share_hi:.0f} times the compensator's largest share. Carried through the regression of eq 34, it "
        f"gives ±{width['K_c']:.0f} % for K_c and ±{width['s0']:.0f} % for s0 (the posterior, held in by K_c > 0 and "
        f"0 < s0 < a + L, {posterior_width['K_c']:.0f} % and {posterior_width['s0']:.0f} %), against Table IV's 21.5 % and 5.9 %.",
        "",
        f"Reaching Table IV's widths needs the per-angle compliances {factor['K_c']:.0f} times (K_c) and "
        f"{factor['s0']:.0f} times (s0) more precise: ±{precision['needed_per_angle_3sd_pct']:.3f} % at 3σ. That is a "
        f"tracker {worst:.0f} times less noisy ({noise_um.min() / worst:.2f}–{noise_um.max() / worst:.2f} μm per "
        f"coordinate instead of {noise_um.min():.0f}–{noise_um.max():.0f} μm) or about {float(f'{worst**2:.2g}'):.0f} "
        "times as many repeats.",
        "",
        "A stiffer spring would raise the share, and the sd of K_c hardly depends on K_c, so a spring about "
        f"{stiff} times stiffer (K_c ≈ {stiff * Kc:.0f} N/mm) would reach 21.5 % on this campaign. But a compensator is "
        "sized to balance the arm's weight over its range of q2. With the twin's link masses (forearm horizontal, q2 "
        f"from −140° to 0°, the weight's joint-2 torque up to {balance[1.0]['weight_max'] / 1e3:.1f} kN·m), the config's "
        f"spring with its best free length leaves a residual torque of {balance[1.0]['residual_rms'] / 1e3:.2f} kN·m rms; "
        f"a spring 10 times stiffer leaves {balance[10.0]['residual_rms'] / 1e3:.1f} kN·m and one {stiff} times stiffer "
        f"{balance[float(stiff)]['residual_rms'] / 1e3:.0f} kN·m, whatever its free length. A compensator that balances "
        "the arm therefore adds only about a tenth of a percent to the joint-2 stiffness, and with the per-angle "
        "precision that Table IV's own k2..k6 widths imply, K_c and s0 cannot be determined to 21.5 % and 5.9 %. Those "
        "widths would need a measurement about fifty times more precise than the one behind Table IV's joint "
        "compliances, or Table IV's k_c in other units, which would no longer balance the arm.",
        "",
    ]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Write the elastostatic identification report.")
    parser.add_argument("--config", default="data/kr270.toml")
    parser.add_argument("--plan", default="data/table3_plan.csv")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("-o", "--output", default="reports/elastostatic.md")
    args = parser.parse_args(argv)
    output = Path(args.output)
    figure = output.with_name(output.stem + "_joint2.png")
    output.write_text(build_report(args.config, args.plan, args.seed, figure), encoding="utf-8")


if __name__ == "__main__":
    main()
