"""The geometry report: Table I through the closed-form fits and the posterior, beside Table II.

:func:`write_geometry_report` writes ``geometry.md`` and its figures; the
Monte-Carlo studies it quotes are public so that tests can check them:
:func:`arc_fit_study` (known-angle fit against standard circle fits and the
Cramér-Rao bounds) and :func:`coverage_study` (frequentist coverage of the
posterior's mean ± k sd intervals on simulated campaigns).

Run ``python -m bayescal.reports.geometry data/table1_geometry.csv reports`` to
regenerate the report.
"""

from __future__ import annotations

import argparse
import math
import warnings
from collections.abc import Sequence
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.geometry.circle import geometric_fit, hyper_fit, kasa_fit, known_angle_crb, unknown_angle_crb
from bayescal.geometry.arcs import (
    LEVER_MARKER,
    CompensatorGeometryModel,
    MarkerLayout,
    concentric_fit,
    known_angle_fit,
    read_arc_points,
)
from bayescal.geometry.posterior import GeometryPosteriorModel, default_sampler
from bayescal.sampling.protocol import Sampler
from bayescal.reports.plots import plot_arc_fit, plot_eta_curves
from bayescal.sampling.summary import ConvergenceWarning
from bayescal.reference import REFERENCE_FILE, read_paper_reference
from bayescal.tables import markdown_table
from bayescal.units import DEG, MM

__all__ = ["arc_fit_study", "coverage_study", "write_geometry_report"]

STUDY_SIGMA = 0.05 * MM
"""Tracker noise per coordinate of the simulated campaigns (m), about the P1 residual scale on Table I."""


def arc_fit_study(layout: MarkerLayout, q2: Sequence[float], sigma: float, n_rep: int, rng: np.random.Generator) -> pd.DataFrame:
    """Monte-Carlo errors of the lever-arc fits on simulated P1 points.

    Parameters
    ----------
    layout
        The true marker layout (only P1 is used).
    q2
        Joint angles in rad.
    sigma
        Noise sd per coordinate in m.
    n_rep
        Number of simulated arcs.
    rng
        Random generator.

    Returns
    -------
    pandas.DataFrame
        Indexed by method (``known-angle``, ``geometric``, ``hyper``, ``kasa``,
        ``CRB known angles``, ``CRB unknown angles``), columns ``rmse_L_mm``
        and ``rmse_centre_mm`` (root mean square Euclidean error of the
        centre); the CRB rows hold the bounds' square roots.
    """
    q2 = np.asarray(q2, dtype=float)
    exact = layout.positions(q2)[LEVER_MARKER]
    fits = {"known-angle": [], "geometric": [], "hyper": [], "kasa": []}
    for _ in range(n_rep):
        noisy = exact + sigma * rng.standard_normal(exact.shape)
        hyper = hyper_fit(noisy)
        for method, fit in (
            ("known-angle", known_angle_fit(q2, noisy)),
            ("geometric", geometric_fit(noisy, start=hyper)),
            ("hyper", hyper),
            ("kasa", kasa_fit(noisy)),
        ):
            fits[method].append((fit.radius, *fit.centre))
    rows = {}
    for method, values in fits.items():
        values = np.array(values)
        rows[method] = (
            np.sqrt(np.mean((values[:, 0] - layout.L) ** 2)),
            np.sqrt(np.mean(np.sum((values[:, 1:] - layout.p2) ** 2, axis=1))),
        )
    known_bound = known_angle_crb(q2, layout.L, layout.phi, sigma, layout.sense)
    unknown_bound = unknown_angle_crb(layout.phi + layout.sense * q2, sigma)
    rows["CRB known angles"] = (np.sqrt(known_bound[2, 2]), np.sqrt(known_bound[0, 0] + known_bound[1, 1]))
    rows["CRB unknown angles"] = (np.sqrt(unknown_bound[2, 2]), np.sqrt(unknown_bound[0, 0] + unknown_bound[1, 1]))
    frame = pd.DataFrame.from_dict(rows, orient="index", columns=["rmse_L_mm", "rmse_centre_mm"]) / MM
    frame.index.name = "method"
    return frame


def _truth(layout: MarkerLayout) -> dict[str, float]:
    flip = 1.0 if layout.sense < 0 else -1.0
    a = layout.p2 - layout.p0
    return {
        "L": layout.L / MM,
        "a_x": a[0] / MM,
        "a_y": flip * a[1] / MM,
        "phi": flip * layout.phi / DEG,
        "p2_x": layout.p2[0] / MM,
        "p2_y": layout.p2[1] / MM,
        "p0_x": layout.p0[0] / MM,
        "p0_y": layout.p0[1] / MM,
    }


def coverage_study(
    layout: MarkerLayout,
    q2: Sequence[float],
    sigma: float,
    n_rep: int,
    model: GeometryPosteriorModel,
    rng: np.random.Generator,
) -> pd.DataFrame:
    """Frequentist coverage of the posterior intervals mean ± k sd (k = 1, 2, 3) on simulated campaigns.

    Each replication simulates all markers at the angles ``q2`` with noise
    ``sigma`` (m), samples the posterior with ``model`` and checks whether
    each interval holds the truth.  The interval's posterior content (its
    probability under the posterior, from the draws) is averaged alongside:
    a calibrated posterior covers at that rate (under a Gaussian posterior
    it is 68.3 %, 95.4 % and 99.7 %).

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter (``L, a_x, a_y, phi, p2_x, p2_y, p0_x, p0_y``),
        columns ``covered_k`` (fraction of replications whose interval held
        the truth) and ``content_k`` (mean posterior content) for k = 1, 2, 3,
        and ``n_rep``.
    """
    truth = _truth(layout)
    hits = {name: np.zeros(3) for name in truth}
    content = {name: np.zeros(3) for name in truth}
    k = np.arange(1, 4)
    for _ in range(n_rep):
        points = layout.simulate(q2, sigma, rng)
        with warnings.catch_warnings():
            # The study runs deliberately short chains: its coverage is the test of them.
            warnings.simplefilter("ignore", ConvergenceWarning)
            draws = model.fit(points, rng=rng).tree["posterior"]
        for name, value in truth.items():
            x = draws[name].values.ravel()
            mean, sd = x.mean(), x.std(ddof=1)
            hits[name] += np.abs(value - mean) <= k * sd
            content[name] += np.mean(np.abs(x[:, None] - mean) <= k * sd, axis=0)
    rows = {
        name: {**{f"covered_{j}": hits[name][j - 1] / n_rep for j in k}, **{f"content_{j}": content[name][j - 1] / n_rep for j in k}}
        for name in truth
    }
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame["n_rep"] = n_rep
    frame.index.name = "parameter"
    return frame


def _markdown(frame: pd.DataFrame, digits: int = 3) -> str:
    def cell(value) -> str:
        if isinstance(value, (float, np.floating)):
            return f"{value:.{digits}f}"
        return str(value)

    rows = [[index, *map(cell, row)] for index, row in zip(frame.index, frame.to_numpy())]
    return markdown_table([frame.index.name or "", *frame.columns], rows)


def _along_arc(points, fit_p0: np.ndarray, name: str, residual: np.ndarray) -> np.ndarray:
    _, xyz = points.of(name)
    d = xyz[:, :2] - fit_p0
    tangent = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    return np.sum(residual * tangent, axis=1)


def write_geometry_report(
    points_path: str | PathLike[str],
    out_dir: str | PathLike[str],
    reference_path: str | PathLike[str] | None = None,
    seed: int = 1,
    n_arc_rep: int = 2000,
    n_coverage_rep: int = 200,
    sampler: Sampler | None = None,
) -> Path:
    """Run the geometry identification on a data file and write ``geometry.md`` with figures.

    Parameters
    ----------
    points_path
        Marker points (``data/table1_geometry.csv``).
    out_dir
        Directory of the report; ``geometry.md``, ``geometry_arcs.png`` and
        ``geometry_eta.png`` are written there.
    reference_path
        Published values (``data/paper_reference.csv``); ``None`` omits the comparison.
    seed
        Seed of every random number used.
    n_arc_rep, n_coverage_rep
        Replications of the two Monte-Carlo studies.
    sampler
        Sampler of the two posteriors of the data (default
        :func:`~bayescal.geometry.posterior.default_sampler`); the coverage
        study always uses 2 chains of 400 + 400 steps.

    Returns
    -------
    pathlib.Path
        The written Markdown file.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    points = read_arc_points(points_path)
    reference = read_paper_reference(reference_path) if reference_path is not None else None
    closed = CompensatorGeometryModel().fit(points)
    concentric = GeometryPosteriorModel("concentric", sampler=sampler).fit(points, rng=rng)
    rigid = GeometryPosteriorModel("rigid", sampler=sampler).fit(points, rng=rng)
    summary = concentric.summary()
    rigid_summary = rigid.summary()
    p0 = closed.p0[:2]

    q1, _ = points.of(LEVER_MARKER)
    q2_sorted = np.sort(q1)
    layout = MarkerLayout.from_fit(closed, points)
    arc_study = arc_fit_study(layout, q2_sorted, STUDY_SIGMA, n_arc_rep, rng)
    light = GeometryPosteriorModel("concentric", sampler=default_sampler(n_chains=2, n_tune=400, n_draws=400))
    coverage = coverage_study(layout, q2_sorted, STUDY_SIGMA, n_coverage_rep, light, rng)

    along = {name: _along_arc(points, rigid.closed_form.p0[:2], name, rigid.residuals[name]) for name in points.cylinder_markers}
    figure = plot_arc_fit(points, closed, {"rigid, along-arc": along})
    figure.savefig(out / "geometry_arcs.png", dpi=120)
    g = concentric.geometry
    s0_values = [0.0, 0.2, 0.4]
    s0_table = None
    if reference is not None and "s0" in reference.index:
        s0_table = float(reference.loc["s0", "value"]) * MM
        s0_values.append(s0_table)
    s0_values.append(g.a - g.L)
    plot_eta_curves(g, s0_values, highlight=s0_table).savefig(out / "geometry_eta.png", dpi=120)

    text = _report_text(points, points_path, reference, closed, concentric, rigid, summary, rigid_summary, arc_study, coverage, seed, s0_values, p0)
    path = out / "geometry.md"
    path.write_text(text, encoding="utf-8")
    return path


def _report_text(points, points_path, reference, closed, concentric, rigid, summary, rigid_summary, arc_study, coverage, seed, s0_values, p0) -> str:
    lever = closed.lever
    d = concentric.diagnostics
    rows = ["L", "a_x", "a_y"]
    lines = [
        "# Compensator geometry from the laser-tracker arcs of Table I",
        "",
        f"Generated by `python -m bayescal.reports.geometry {points_path} <dir>` (seed {seed}); every number below is "
        "computed by the code from the data file. Paper values are from Klimchik et al., Table II.",
        "",
        "## Data",
        "",
        f"{len(points.marker)} points: markers {', '.join(points.markers)} at joint angles "
        f"{', '.join(f'{q / DEG:g}' for q in np.sort(points.of(LEVER_MARKER)[0]))} deg (x, y in mm; no z).",
        "",
        "## Closed-form fits (eqs 10-29)",
        "",
        f"Known-angle fit of P1 (eqs 10-19): the best orthogonal R has det R = {np.linalg.det(lever.R):+.0f}, "
        f"a {'reflection' if lever.sense < 0 else 'rotation'}: the lever turns "
        f"{'clockwise' if lever.sense < 0 else 'counter-clockwise'} in the tracker's (x, y) as q2 increases "
        "(the tracker's Z axis and the joint angle turn opposite ways). The lever angle at q2 = 0 is "
        f"phi = {lever.phi / DEG:.3f} deg and L = {lever.radius / MM:.4f} mm. "
        f"Concentric fit of {', '.join(points.cylinder_markers)} (eqs 20-24, planar): p0 = ({p0[0] / MM:.3f}, {p0[1] / MM:.3f}) mm.",
        "",
        _markdown(closed.summary(), 4),
        "",
        "Residual rms: vector length for P1, radial distance for the cylinder markers (their position along "
        "the arc is free in the concentric model).",
        "",
        "## Posterior (concentric cylinder markers, the paper's model)",
        "",
        f"Sampler: {concentric.tree.attrs['sampler']}. {d['n_chains']} chains × {d['n_draws']} draws: "
        f"R-hat max {d['r_hat_max']:.4f}, ESS bulk min {d['ess_bulk_min']:.0f}, ESS tail min {d['ess_tail_min']:.0f}. "
        "`lo3`/`hi3` are mean ∓ 3 sd, the paper's ±3σ.",
        "",
        _markdown(summary[["mean", "sd", "lo3", "hi3", "r_hat", "ess_bulk", "unit"]], 4),
        "",
    ]
    if reference is not None:
        comparison = {}
        for name in rows:
            ours = summary.loc[name]
            value, ci3 = reference.loc[name, "value"], reference.loc[name, "ci3"]
            comparison[name] = {
                "ours mean [mm]": ours["mean"],
                "ours ±3σ [mm]": 3 * ours["sd"],
                "Table II [mm]": value,
                "Table II ±3σ [mm]": ci3,
                "difference [mm]": ours["mean"] - value,
                "difference / our sd": (ours["mean"] - value) / ours["sd"],
                "difference / paper σ": (ours["mean"] - value) / (ci3 / 3),
                "paper value inside our ±3σ": "yes" if abs(ours["mean"] - value) <= 3 * ours["sd"] else "no",
            }
        table = pd.DataFrame.from_dict(comparison, orient="index")
        table.index.name = "parameter"
        lines += ["### Beside Table II", "", _markdown(table, 3), ""]
        lines += _a_y_discussion(points, closed, summary, rigid_summary, reference)
    lines += _rigid_section(points, closed, concentric, rigid, summary, rigid_summary)
    lines += [
        "## Figures",
        "",
        "![Marker points, fitted arcs and residuals](geometry_arcs.png)",
        "",
        "Left: Table I's points with the known-angle arc of P1 and the concentric arcs of the cylinder markers. "
        "Middle: P1's residuals of the known-angle fit. Right: the cylinder markers' radial residuals of the "
        "concentric fit and the along-arc residuals of the rigid model at its posterior mean.",
        "",
        "![eta curves](geometry_eta.png)",
        "",
        "The coefficient eta(q2) of eq 9 (the paper's Fig. 3) with the posterior-mean geometry, for "
        f"s0 = {', '.join(f'{s / MM:.0f}' for s in s0_values)} mm (the thick curve is Table IV's s0; the last "
        "value is a - L, the shortest spring length, above which the spring would push).",
        "",
    ]
    lines += _studies_section(arc_study, coverage)
    lines += [
        "## Limitations",
        "",
        "- The model is planar in the tracker's (x, y), as the paper's: Table I has no z, and a tilt of the joint "
        "axes from the tracker's Z would bend the projected arcs into ellipses.",
        "- The joint angles q2 are taken as exact; an encoder offset would rotate phi and nothing else.",
        "- The residuals of the cylinder markers are systematic, not independent noise (see above); their σ absorbs "
        "the misfit, which widens the intervals of a_x and a_y but cannot make them exact.",
        "",
    ]
    return "\n".join(lines)


def _a_y_discussion(points, closed, summary, rigid_summary, reference) -> list[str]:
    paper = reference.loc["a_y", "value"]
    ours = summary.loc["a_y"]
    singles = {}
    for name in points.cylinder_markers:
        single = concentric_fit({name: points.of(name)[1][:, :2]})
        # a_y follows the frame of the combined fit, which flips y when the arc turns the other way.
        singles[name] = (-1.0 if closed.mirrored else 1.0) * (closed.p2[1] - single.centre[1]) / MM
    residuals = {name: closed.cylinder.residuals[name] / MM for name in points.cylinder_markers}
    pattern = "; ".join(
        f"{name}: {', '.join(f'{r:+.2f}' for r in residuals[name][np.argsort(points.of(name)[0])])}" for name in residuals
    )
    sigma_cylinder = summary.loc["sigma[cylinder]", "mean"]
    implied = {
        name: sigma_cylinder * (reference.loc[name, "ci3"] / 3) / summary.loc[name, "sd"] for name in ("a_x", "a_y")
    }
    lever_rms = closed.residuals_rms[LEVER_MARKER] / MM
    cylinder_rms = max(closed.residuals_rms[name] for name in points.cylinder_markers) / MM
    return [
        "### About a_y",
        "",
        f"Our a_y is {ours['mean']:.2f} ± {ours['sd']:.2f} mm (mean ± sd), Table II gives {paper:.2f} ± "
        f"{reference.loc['a_y', 'ci3']:.2f} (±3σ): a difference of {ours['mean'] - paper:+.2f} mm, "
        f"{abs(ours['mean'] - paper) / ours['sd']:.1f} of our sd and "
        f"{abs(ours['mean'] - paper) / (reference.loc['a_y', 'ci3'] / 3):.1f} of the paper's σ. The closed-form "
        f"(algebraic, eqs 20-24) fit gives {closed.geometry.a_y / MM:.2f} mm, so the difference is not a sampling "
        "effect. Its likely cause is how weakly Table I fixes p0:",
        "",
        "- p0 from one cylinder marker alone: a_y = "
        + ", ".join(f"{v:.2f} mm ({k})" for k, v in singles.items())
        + ". Each arc spans only the cylinder's swing, so its centre is poorly fixed along the arc's mean radius, "
        "and the two markers' centres disagree by several mm; the shared centre is their compromise and moves "
        "with any weighting or model choice.",
        f"- The cylinder markers' radial residuals (mm, by increasing q2) are not noise-like: {pattern}. Both "
        f"markers show the same pattern, and their rms (up to {cylinder_rms:.2f} mm) is "
        f"{cylinder_rms / lever_rms:.1f} times the P1 residual ({lever_rms:.3f} mm), so the planar concentric model "
        "does not describe these markers to tracker accuracy.",
        f"- The rigid-cylinder model (below) moves a_y to {rigid_summary.loc['a_y', 'mean']:.2f} mm.",
        "",
        "Our posterior sds of a_x and a_y scale with the cylinder markers' σ. Scaled that way, the paper's "
        f"intervals correspond to σ_cylinder ≈ {implied['a_x']:.3f} mm (a_x) and {implied['a_y']:.3f} mm (a_y), "
        f"against the {sigma_cylinder:.3f} mm these markers show on Table I (P1: {summary.loc['sigma[lever]', 'mean']:.3f} mm): "
        "our intervals are wider because the noise model lets these markers have the scatter they have.",
        "",
    ]


def _rigid_section(points, closed, concentric, rigid, summary, rigid_summary) -> list[str]:
    names = ["L", "a_x", "a_y", "phi", "sigma[lever]", "sigma[cylinder]"]
    table = pd.DataFrame(
        {
            "concentric mean": summary.loc[names, "mean"],
            "concentric sd": summary.loc[names, "sd"],
            "rigid mean": rigid_summary.loc[names, "mean"],
            "rigid sd": rigid_summary.loc[names, "sd"],
            "unit": summary.loc[names, "unit"],
        }
    )
    table.index.name = "parameter"
    rms = pd.DataFrame(
        {
            "concentric rms [mm] (radial)": {k: v / MM for k, v in concentric.residuals_rms.items()},
            "rigid rms [mm] (vector)": {k: v / MM for k, v in rigid.residuals_rms.items()},
        }
    )
    rms.index.name = "marker"
    drift = []
    layout = MarkerLayout.from_fit(closed, points)
    for name in points.cylinder_markers:
        q2, xyz = points.of(name)
        d = xyz[:, :2] - layout.p0
        lever = layout.positions(q2)[LEVER_MARKER] - layout.p0
        relative = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - np.arctan2(lever[:, 1], lever[:, 0]))))
        drift.append(
            f"{name} {np.ptp(np.unwrap(relative)) / DEG:.2f} deg "
            f"({np.ptp(np.unwrap(relative)) * closed.cylinder.radii[name] / MM:.2f} mm along its arc)"
        )
    return [
        "## Cylinder markers: concentric (the paper's) or rigid on the cylinder",
        "",
        "The paper fits the cylinder markers as concentric arcs with unknown angles. If they are rigid on the "
        "cylinder, whose axis runs from P0 through P1, their angles follow from the geometry and the model is "
        "much stronger. Both posteriors:",
        "",
        _markdown(table, 4),
        "",
        _markdown(rms, 3),
        "",
        "The rigid model requires each marker's angle about p0, measured from the direction p0→P1, to be "
        f"constant; on Table I it varies over the six angles by {', '.join(drift)}, far beyond P1's noise. The "
        "markers are therefore not rigid on a cylinder that points exactly at P1 (or the planar model misses part "
        "of the motion), the rigid model's σ absorbs that misfit, and its a_x interval, narrower than the "
        "concentric one, is not to be trusted. The report and the CLI use the concentric model by default.",
        "",
    ]


def _studies_section(arc_study: pd.DataFrame, coverage: pd.DataFrame) -> list[str]:
    known = arc_study.loc["known-angle"]
    bound = arc_study.loc["CRB known angles"]
    best = arc_study.loc[["geometric", "hyper"]].min()
    n_rep = int(coverage["n_rep"].iloc[0])
    lines = [
        "## Monte-Carlo studies",
        "",
        f"Simulated campaigns shaped like Table I: the same joint angles, the closed-form geometry of Table I as the "
        f"truth (cylinder markers rigid on the cylinder), isotropic Gaussian noise of sd {STUDY_SIGMA / MM:.2f} mm per "
        "coordinate (about the P1 residual scale of Table I).",
        "",
        "### Lever arc: known-angle fit against circle fits and the Cramér-Rao bound",
        "",
        _markdown(arc_study, 4),
        "",
        f"Known-angle RMSE / CRB: L {known['rmse_L_mm'] / bound['rmse_L_mm']:.3f}, centre "
        f"{known['rmse_centre_mm'] / bound['rmse_centre_mm']:.3f}. Best of the geometric and hyper fits / known-angle: "
        f"L {best['rmse_L_mm'] / known['rmse_L_mm']:.2f}, centre {best['rmse_centre_mm'] / known['rmse_centre_mm']:.2f}.",
        "",
        f"### Coverage of the posterior's mean ± k sd intervals ({n_rep} simulated campaigns, 2 chains of 400 + 400 steps each)",
        "",
        _markdown(coverage.drop(columns=["n_rep"]), 3),
        "",
        "`covered_k` is the fraction of campaigns whose interval held the truth, `content_k` the interval's mean "
        "posterior probability (the rate a calibrated posterior covers at; 0.683, 0.954, 0.997 for a Gaussian). "
        f"Binomial standard error at the ±3σ level: {math.sqrt(0.99 * 0.01 / n_rep):.3f}.",
        "",
    ]
    return lines


def main(argv: Sequence[str] | None = None) -> None:
    """Command-line entry: ``python -m bayescal.reports.geometry POINTS OUT_DIR [--reference CSV] [--seed N]``."""
    parser = argparse.ArgumentParser(description="Write the compensator geometry report.")
    parser.add_argument("points")
    parser.add_argument("out_dir")
    parser.add_argument("--reference", default=str(REFERENCE_FILE))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--coverage-rep", type=int, default=200)
    args = parser.parse_args(argv)
    path = write_geometry_report(args.points, args.out_dir, args.reference, args.seed, n_coverage_rep=args.coverage_rep)
    print(path)


if __name__ == "__main__":
    main()
