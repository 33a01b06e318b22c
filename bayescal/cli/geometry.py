"""``bayescal geometry``: the compensator geometry L, a_x, a_y with ±3σ intervals from tracker arcs."""

from __future__ import annotations

import argparse
from pathlib import Path

from bayescal.units import MM

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically
from ._registered import add_registration_option, read_arcs_in_paper_frame, registration_lines

# Table II's parameters, set beside ours in the text output.
_PAPER_ROWS = ("L", "a_x", "a_y")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``bayescal geometry``."""
    parser = subparsers.add_parser(
        "geometry",
        help="identify the gravity compensator's geometry from laser-tracker arcs",
        description=(
            "Identify the compensator geometry (L, a_x, a_y, phi) from tracker points of the markers P1, P01, P02, "
            "... at several joint-2 angles: the closed-form fits of Klimchik et al. (eqs 10-29) and the Bayesian "
            "posterior with mean, sd and mean ± 3 sd, beside the paper's Table II."
        ),
    )
    parser.add_argument("points", help="CSV with columns q2_deg, marker, x_mm, y_mm (optional z_mm)")
    parser.add_argument(
        "--cylinder-model",
        choices=("concentric", "rigid"),
        default="concentric",
        help="model of the cylinder markers: concentric arcs with free angles (the paper's, default) "
        "or markers rigid on the cylinder P0->P1",
    )
    parser.add_argument("--posterior", metavar="PATH", help="save the posterior as a NetCDF DataTree")
    parser.add_argument(
        "--reference",
        metavar="PATH",
        help="CSV of published values (table, parameter, unit, value, ci3); default: the repository's data/paper_reference.csv",
    )
    parser.add_argument(
        "--chains",
        type=whole_number(2, "R-hat needs at least 2 chains"),
        default=4,
        help="independent chains, at least 2 (default 4)",
    )
    parser.add_argument("--tune", type=whole_number(1), default=200, help="discarded steps per chain (default 200)")
    parser.add_argument("--draws", type=whole_number(1), default=1000, help="kept draws per chain (default 1000)")
    add_registration_option(parser, "the points (with z_mm)")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    """Fit the geometry and return the JSON payload and a readable table."""
    import numpy as np

    from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
    from bayescal.reference import REFERENCE_FILE, beside_published, read_paper_reference

    check_output("--posterior", args.posterior, {"the points file": args.points, "the --reference file": args.reference,
                                                  "the --registration file": args.registration})
    points, transfer = read_arcs_in_paper_frame(args, args.points)
    reference_path = Path(args.reference) if args.reference else REFERENCE_FILE
    reference = None
    if args.reference or reference_path.is_file():
        reference = read_paper_reference(reference_path)
    model = GeometryPosteriorModel(args.cylinder_model, sampler=geometry_sampler(n_chains=args.chains, n_tune=args.tune, n_draws=args.draws))
    result = model.fit(points, rng=args.seed)
    if args.posterior:
        write_atomically("--posterior", args.posterior, result.save)

    summary = result.summary()
    closed_table = result.closed_form.summary()
    payload = {"source": args.points} | result.to_json() | {"posterior_file": args.posterior, "seed": args.seed}
    if transfer is not None:
        payload["registration"] = {"source": args.registration} | transfer.to_json()
    paper = None
    if reference is not None:
        paper = beside_published(summary.loc[[name for name in _PAPER_ROWS if name in summary.index], ["mean", "sd"]], "II", reference)
        paper = paper[paper["published"].notna()]
        payload["paper"] = {
            name: {
                "value": float(row["published"]),
                "lo3": float(row["published"] - row["published_half_width_3sd"]),
                "hi3": float(row["published"] + row["published_half_width_3sd"]),
                "unit": summary.loc[name, "unit"],
                "table": "Klimchik et al., Table II",
                "difference_in_sd": float(row["difference_in_sd"]),
            }
            for name, row in paper.iterrows()
        }
    lever = float(np.hypot(summary.loc["a_x", "mean"], summary.loc["a_y", "mean"]))
    text = "\n".join([_text(args, summary, closed_table, result, paper), *registration_lines(transfer, args.registration, lever)])
    return CommandOutput(payload, text)


def _text(args, summary, closed_table, result, paper) -> str:
    from bayescal.numbers import decimals_of, fixed, rounded_pair

    header = (
        f"{'parameter':<16}{'unit':<5}{'mean':>11}{'sd':>9}{'mean-3sd':>11}{'mean+3sd':>11}{'r_hat':>7}"
        f"{'closed form':>13}{'Table II':>10}{'±3σ':>7}"
    )
    lines = [
        f"Compensator geometry from {args.points} ({result.cylinder_model} cylinder markers, seed {args.seed})",
        "",
        header,
        "-" * len(header),
    ]
    for name, row in summary.iterrows():
        # Every number of a row to the decimal of the second significant digit of its sd (bayescal.numbers).
        shown = fixed(decimals_of(row["sd"]))
        closed = f"{shown(closed_table.loc[name, 'value']):>13}" if name in closed_table.index else " " * 13
        published = ""
        if paper is not None and name in paper.index:
            # As Table II prints them: two decimals, which is all its half-widths give.
            published = f"{paper.loc[name, 'published']:10.2f}{paper.loc[name, 'published_half_width_3sd']:7.2f}"
        mean, sd = rounded_pair(row["mean"], row["sd"])
        lines.append(
            f"{name:<16}{row['unit']:<5}{mean:>11}{sd:>9}{shown(row['lo3']):>11}{shown(row['hi3']):>11}"
            f"{row['r_hat']:7.3f}{closed}{published}"
        )
    d = result.diagnostics()
    rms = ", ".join(f"{name} {value / MM:.3f}" for name, value in result.residuals_rms.items())
    sense = result.closed_form.lever
    lines += [
        "",
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f} "
        f"({d['n_chains']} chains x {d['n_draws']} draws)",
        f"residual rms at the posterior mean [mm]: {rms}",
        f"P1 arc: {'clockwise' if sense.sense < 0 else 'counter-clockwise'} in (x, y) as q2 increases "
        f"(the best orthogonal R of eq 19 is a {'reflection' if sense.sense < 0 else 'rotation'})",
    ]
    if paper is not None:
        lines.append("Table II: Klimchik et al., published value and ±3σ half-width")
    if args.posterior:
        lines.append(f"posterior saved to {args.posterior}")
    return "\n".join(lines)
