"""``bayescal critique``: what the classical VJM model gets wrong on a campaign, the likely cause, and the gain of fixing it.

With ``--geometry POINTS.csv`` the same for the compensator-geometry model on tracker arcs (Table I).
"""

from __future__ import annotations

import argparse

from bayescal.output import guard_outputs, write_folder

from ._command import CommandOutput, add_common_options, whole_number
from ._nests import add_nests_option, read_nests_in_base
from ._registered import add_registration_option, read_arcs_in_paper_frame, read_campaign_in_base, registration_lines

__all__ = ["add_parser", "run"]

CATALOGUES = "{catalogue}"
"""Where the description names the candidates: filled from the catalogues when the help is shown."""


class _CatalogueHelp(argparse.HelpFormatter):
    """Names the critique's candidates in the description from their catalogues, when the help is shown.

    The catalogues are the one source of the candidates; building them imports the critique, which
    the other subcommands, whose parsers are built on every run, do not need.
    """

    def _format_text(self, text: str) -> str:
        if CATALOGUES in text:
            from bayescal.critique.extensions import CATALOGUE
            from bayescal.critique.geometry import GEOMETRY_CATALOGUE

            text = text.replace(CATALOGUES, ", ".join(CATALOGUE), 1).replace("{geometry}", ", ".join(GEOMETRY_CATALOGUE), 1)
        return super()._format_text(text)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "critique",
        help="criticise the classical VJM model on a campaign: misfit, likely cause, held-out gain",
        description=(
            "Compare the classical serial VJM model (constant joint compliances, eq 30) with its extensions "
            f"({CATALOGUES}; drift only where the campaign's repeated readings can show it, and measured and removed "
            "instead with --nests) by their "
            "predictive density on held-out configurations, name the causes whose gain is clear of its "
            "uncertainty, and report the gain. With --geometry, criticise the planar two-step compensator-geometry "
            "model on tracker arcs instead ({geometry}; held-out joint angles)."
        ),
        formatter_class=_CatalogueHelp,
    )
    parser.add_argument("campaign", nargs="?", help="campaign CSV (bayescal simulate writes one), or a positions file of a cell of "
                        "measured points (then the model ladder of `bayescal kinematics`, scored held out); not with --geometry")
    parser.add_argument(
        "--config", help="cell TOML file: robot URDF, compensator, tool markers, tracker, test pose; not with --geometry"
    )
    parser.add_argument(
        "--geometry",
        metavar="POINTS.csv",
        help="criticise the compensator-geometry model on tracker points (q2_deg, marker, x_mm, y_mm) instead of a campaign",
    )
    parser.add_argument("--folds", type=whole_number(2, "folds of the cross-validation"), default=10,
                        help="on a positions file (a cell with [markers]): folds of the cross-validation by configuration (default 10)")
    parser.add_argument("--figures", metavar="DIR", help="write the figures into this folder: held-out residuals and LOO-PIT (with --geometry: held-out residuals per marker)")
    add_registration_option(parser, "the campaign's positions (or the --geometry points, with z_mm)")
    add_nests_option(parser)
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    import numpy as np

    from bayescal.errors import InputError

    if args.geometry is not None:
        if args.campaign is not None or args.config is not None or args.nests is not None or args.drift_from_repeats:
            raise InputError("--geometry takes the points file only: drop the campaign, --config, --nests and "
                             "--drift-from-repeats", source="--geometry")
        return _run_geometry(args)
    if args.campaign is None or args.config is None:
        raise InputError("expected a campaign CSV and --config CELL.toml, or --geometry POINTS.csv")
    from bayescal.cell.cellfile import is_points_cell

    if is_points_cell(args.config):
        return _run_ladder(args)

    from bayescal.cell.config import load_cell
    from bayescal.critique import Critique
    from bayescal.critique.figures import FIGURES, write_figures

    inputs = {"the campaign": args.campaign, "the config": args.config, "the --registration file": args.registration,
              "the --nests file": args.nests}
    guard_outputs(inputs, folders={"--figures": (args.figures, FIGURES)})
    cell = load_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.robot.source}, folders={"--figures": (args.figures, FIGURES)})
    campaign, cell, transfer = read_campaign_in_base(args, args.campaign, cell)
    results = Critique(cell).run(campaign, np.random.default_rng(args.seed), nests=read_nests_in_base(args, campaign),
                                 repeats=args.drift_from_repeats)
    figures = []
    if args.figures is not None:
        figures = [str(path) for path in write_folder("--figures", args.figures, lambda folder: write_figures(results, folder))]
    payload = results.to_json() | {"seed": args.seed}
    if figures:
        payload["figures"] = figures
    if transfer is not None:
        payload["registration"] = {"source": args.registration} | transfer.to_json()
    text = "\n".join([results.document(figures).as_text(), *registration_lines(transfer, args.registration)])
    return CommandOutput(payload=payload, text=text)


def _run_ladder(args: argparse.Namespace) -> CommandOutput:
    """The model ladder on a positions file of a cell of measured points (`bayescal kinematics`)."""
    from bayescal.errors import InputError
    from bayescal.kinematics import load_points_cell, read_positions
    from bayescal.kinematics.ladder import ModelLadder

    if args.figures is not None or args.registration is not None or args.nests is not None or args.drift_from_repeats:
        given = next(flag for flag, value in (("--figures", args.figures), ("--registration", args.registration), ("--nests", args.nests),
                                              ("--drift-from-repeats", args.drift_from_repeats or None)) if value is not None)
        raise InputError("on a positions file the critique takes --config, --folds and --json only", source=given)
    cell = load_points_cell(args.config)
    positions = read_positions(args.campaign, cell)
    if len(positions) < args.folds:
        raise InputError(f"{len(positions)} configurations cannot be split into {args.folds} folds", source="--folds")
    findings = ModelLadder(cell, folds=args.folds, seed=args.seed).run(positions)
    return CommandOutput(payload=findings.to_json() | {"seed": args.seed}, text=findings.document().as_text())


def _run_geometry(args: argparse.Namespace) -> CommandOutput:
    from bayescal.critique.figures import GEOMETRY_FIGURES, write_geometry_figures
    from bayescal.critique.geometry import GeometryCritique

    guard_outputs({"the --geometry points": args.geometry, "the --registration file": args.registration},
                  folders={"--figures": (args.figures, GEOMETRY_FIGURES)})
    points, transfer = read_arcs_in_paper_frame(args, args.geometry)
    results = GeometryCritique().run(points)
    payload = results.to_json() | {"seed": args.seed}
    if transfer is not None:
        payload["registration"] = {"source": args.registration} | transfer.to_json()
    text = "\n".join([results.document().as_text(), *registration_lines(transfer, args.registration)])
    if args.figures is not None:
        written = write_folder("--figures", args.figures, lambda folder: write_geometry_figures(results, folder))
        payload["figures"] = [str(path) for path in written]
        text += f"\nfigures: {', '.join(payload['figures'])}"
    return CommandOutput(payload=payload, text=text)
