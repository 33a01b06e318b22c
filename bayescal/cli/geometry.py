"""``bayescal geometry``: the compensator geometry L, a_x, a_y with ±3σ intervals from tracker arcs."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically
from ._registered import add_registration_option, read_arcs_in_paper_frame, registration_lines


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
    from bayescal.reference import REFERENCE_FILE, read_paper_reference

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

    from bayescal.geometry.document import beside_table_ii

    summary = result.summary()
    payload = {"source": args.points} | result.to_json() | {"posterior_file": args.posterior, "seed": args.seed}
    if transfer is not None:
        payload["registration"] = {"source": args.registration} | transfer.to_json()
    if reference is not None:
        payload["paper"] = {
            name: {
                "value": float(row["published"]),
                "lo3": float(row["published"] - row["published_half_width_3sd"]),
                "hi3": float(row["published"] + row["published_half_width_3sd"]),
                "unit": summary.loc[name, "unit"],
                "table": "Klimchik et al., Table II",
                "difference_in_sd": float(row["difference_in_sd"]),
            }
            for name, row in beside_table_ii(summary, reference).iterrows()
        }
    lever = float(np.hypot(summary.loc["a_x", "mean"], summary.loc["a_y", "mean"]))
    document = result.document(args.points, args.seed, reference, args.posterior)
    text = "\n".join([document.as_text(), *registration_lines(transfer, args.registration, lever)])
    return CommandOutput(payload, text)
