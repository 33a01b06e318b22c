"""The elastostatic identification report: a Table III campaign on the twin, identified and judged.

``python -m bayescal.elastostatic_report [--config data/kr270.toml] [--plan data/table3_plan.csv]
[--seed 1] [-o reports/elastostatic.md]`` simulates the campaign, identifies it with the exact and
the linear model, checks the truth against the ±3σ intervals, sets the relative widths beside
Klimchik et al.'s Table IV, measures how much the exact model's correction depends on the assumed
link masses and compensator spring, and carries the posterior to the test pose.
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from .cell import Cell, load_cell
from .elastostatic import TABLE_IV, ElastostaticModel, scale_masses
from .plan import read_plan
from .stiffness import equilibrium
from .testpose import predict_test_pose
from .twin import DigitalTwin
from .units import MM, N_PER_MM, UM, URAD_PER_NM

__all__ = ["build_report", "main"]

NAMES = ["k1", "k2", "k3", "k4", "k5", "k6", "K_c", "s0"]


def _truth(cell: Cell) -> dict[str, float]:
    values = {f"k{j + 1}": cell.compliances[j] / URAD_PER_NM for j in range(6)}
    values["K_c"] = cell.compensator.K_c / N_PER_MM
    values["s0"] = cell.compensator.s0 / MM
    return values


def _table(frame: pd.DataFrame, digits: int = 4) -> str:
    header = "| " + " | ".join([frame.index.name or ""] + list(frame.columns)) + " |"
    rule = "|" + "---|" * (len(frame.columns) + 1)
    rows = []
    for name, row in frame.iterrows():
        cells = [f"{v:.{digits}g}" if isinstance(v, float | np.floating) else str(v) for v in row]
        rows.append("| " + " | ".join([str(name)] + cells) + " |")
    return "\n".join([header, rule, *rows])


def _closed_form_shift(model: ElastostaticModel, campaign, reference, sd) -> dict[str, float]:
    cf, _ = model.estimate(campaign)
    values = {f"k{j + 1}": cf.compliances[j] / URAD_PER_NM for j in range(6)}
    if cf.spring is not None:
        values |= {"K_c": cf.spring[1] / N_PER_MM, "s0": cf.spring[2] / MM}
    return {name: (values[name] - reference[name]) / sd[name] for name in sd if np.isfinite(values.get(name, np.nan))}


def build_report(config: str = "data/kr270.toml", plan_path: str = "data/table3_plan.csv", seed: int = 1) -> str:
    """The Markdown report for the twin's campaign of ``plan_path`` with ``seed``."""
    cell = load_cell(config)
    plan = read_plan(plan_path, cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(seed))
    truth = _truth(cell)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = ElastostaticModel.from_cell(cell)
        results = model.fit(campaign, seed)
        linear = ElastostaticModel.from_cell(cell, model="linear").fit(campaign, seed)
    messages = sorted({str(w.message) for w in caught})
    parameters = results.parameters()

    rows = {}
    for name in NAMES:
        entry = parameters[name]
        paper = TABLE_IV.get(name)
        paper_cells = [paper[0], paper[1], f"{100 * paper[1] / paper[0]:.1f}%"] if paper else ["–", "–", "–"]
        if "mean" not in entry:
            rows[name] = [entry.get("unit", ""), "not identifiable", "", "", truth[name], "", *paper_cells]
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
    units = {name: parameters[name].get("unit", "") for name in NAMES}
    for name in ("k1", "k2", "k3", "k4", "k5", "k6"):
        units[name] = "urad/(N m)"

    comparison = results.linear_vs_exact()
    comparison = comparison.loc[[n for n in comparison.index if n in NAMES or n.startswith("k2_q2")], ["shift_in_sd", "sd_ratio"]]
    sd = {name: parameters[name]["sd"] for name in NAMES if "sd" in parameters[name]}
    means = {name: parameters[name]["mean"] for name in sd}
    truth_shift = {name: (truth[name] - means[name]) / sd[name] for name in sd}

    sensitivity = {}
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

    test_pose = predict_test_pose(
        results,
        cell.robot,
        cell.test_q,
        cell.test_wrench,
        cell.test_point,
        nominal_compensator=cell.compensator,
        nominal_compliances=cell.compliances,
        load_point=cell.test_point,
    )
    loaded = cell.test_q + equilibrium(cell.robot, cell.test_q, cell.compliances, cell.test_wrench, compensator=cell.compensator, load_point=cell.test_point)
    unloaded = cell.test_q + equilibrium(cell.robot, cell.test_q, cell.compliances, np.zeros(6), compensator=cell.compensator, load_point=cell.test_point)
    true_deflection = cell.robot.point_position(loaded, cell.test_point) - cell.robot.point_position(unloaded, cell.test_point)
    against_truth = dataclasses.replace(test_pose, reference=true_deflection)
    block = test_pose.to_json()
    truth_block = against_truth.to_json()["residual_error_mm"]

    d = results.diagnostics()
    dl = linear.diagnostics()
    masses = plan.masses(cell.load_mass)
    noise = np.concatenate([cell.tracker.sigma(campaign.p0), cell.tracker.sigma(campaign.p1)]) / UM
    reasons = {k: v for k, v in results.identifiability.reasons.items() if not k.startswith("k2@")}

    lines = [
        "# Elastostatic identification on the digital twin",
        "",
        f"Generated by `python -m bayescal.elastostatic_report --config {config} --plan {plan_path} --seed {seed}`.",
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
        f"Exact model, {results.sampler_name} sampler, {d['n_chains']} chains × {d['n_draws']} draws; "
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f}. "
        "Intervals are mean ± 3 sd as in the paper; widths are 3 sd / |mean|. k2 is joint 2 without its compensator.",
        "",
        _table(estimates),
        "",
    ]
    for name, reason in reasons.items():
        lines.append(f"- **{name} is not identifiable**: {reason}.")
    lines += [
        "",
        "Truth minus posterior mean, in posterior sd: "
        + ", ".join(f"{name} {value:+.2f}" for name, value in truth_shift.items())
        + ".",
        "",
        "The joint compliances k2..k6 come out with widths comparable to Table IV's. K_c and s0 do not: the "
        "compensator changes the joint-2 stiffness by well under 1 % across q2 (see `reports/twin.md`), so "
        "identifying K_c to Table IV's 21.5 % needs per-angle joint-2 compliances good to a few hundredths of a "
        "percent. With this cell's tracker noise the per-angle compliances (below) are good to about "
        f"{100 * np.nanmedian([3 * results.summary().loc[n, 'sd'] / results.summary().loc[n, 'mean'] for n in results.summary().index if n.startswith('k2_q2')]):.2f} % (±3σ), "
        "so the posterior of K_c is wide and skewed; its mean ± 3 sd interval can reach below zero even though every draw is positive.",
        "",
        "Equivalent joint-2 compliance at each campaign angle (μrad/(N·m)):",
        "",
        _table(results.summary().loc[[n for n in results.summary().index if n.startswith("k2_q2")], ["mean", "sd", "lo3", "hi3"]]),
        "",
        "## Linear against exact model",
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
            lines.append(f"{name} is held at the config's {entry['value']:.3g} {entry['unit']}: {entry['note']}; its uncertainty is not in these numbers.")
    else:
        lines.append(f"Not predicted: {block['reason']}.")
    lines += ["", "## Warnings raised", ""] + [f"- {m}" for m in messages] + [""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Write the elastostatic identification report.")
    parser.add_argument("--config", default="data/kr270.toml")
    parser.add_argument("--plan", default="data/table3_plan.csv")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("-o", "--output", default="reports/elastostatic.md")
    args = parser.parse_args(argv)
    Path(args.output).write_text(build_report(args.config, args.plan, args.seed), encoding="utf-8")


if __name__ == "__main__":
    main()
