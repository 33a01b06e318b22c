"""``bayescal critique``: what the classical VJM model gets wrong on a campaign, the likely cause, and the gain of fixing it.

With ``--geometry POINTS.csv`` the same for the compensator-geometry model on tracker arcs (Table I).
"""

from __future__ import annotations

import argparse
import textwrap

from bayescal.output import guard_outputs, write_folder

from ._command import CommandOutput, add_common_options, whole_number
from ._nests import add_nests_option, nests_lines, read_nests_in_base
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
    from bayescal.kinematics.cell import is_points_cell

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
    text = "\n".join([_text(results, figures), *registration_lines(transfer, args.registration)])
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
    return CommandOutput(payload=findings.to_json() | {"seed": args.seed}, text=findings.text())


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
    text = "\n".join([_geometry_text(results), *registration_lines(transfer, args.registration)])
    if args.figures is not None:
        written = write_folder("--figures", args.figures, lambda folder: write_geometry_figures(results, folder))
        payload["figures"] = [str(path) for path in written]
        text += f"\nfigures: {', '.join(payload['figures'])}"
    return CommandOutput(payload=payload, text=text)


def _outcome_lines(results, held_out: str, baseline: str) -> list[str]:
    """The verdict, every candidate's evidence and the unexplained covariate, for either critique."""
    if results.verdict == "adequate":
        lines = [f"verdict: adequate - no extension predicts held-out {held_out} clearly better than {baseline}"]
    else:
        lines = [f"verdict: misfit - causes in order of gain: {', '.join(results.causes)}"]
    evidence = results.to_json()["evidence"]
    width = max(len("candidate"), *map(len, evidence)) + 2
    lines += ["", f"{'candidate':<{width}}{'step':>5}{'ΔELPD':>10}{'SE':>8}  named"]
    for name, entry in evidence.items():
        lines.append(f"{name:<{width}}{entry['step']:>5}{entry['delta_elpd']:>10.1f}{entry['se']:>8.1f}  {'yes' if entry['named'] else ''}")
    lines.append(f"(ΔELPD: held-out log predictive density gained over {baseline}, in nats; SE: its standard error; docs/glossary.md)")
    if results.unexplained_covariate is not None:
        c = results.probes[results.unexplained_covariate]
        lines.append(
            f"unexplained: the residuals follow {results.unexplained_covariate} (ΔELPD {c.delta_elpd:.1f} ± {c.se:.1f} nats) "
            "and no extension of the catalogue explains it"
        )
    misfit = getattr(results, "lack_of_fit", None)
    if misfit is not None:
        verdict = "misses them" if misfit.significant() else "fits them within the repeats' scatter"
        lines.append(f"repeats: the final model {verdict}: {misfit.describe()}")
        if misfit.significant() and results.unexplained_covariate is None:
            lines.append("unexplained: a misfit the repeats reveal and no candidate of the catalogue matches in shape")
    return lines


def _geometry_text(results) -> str:
    before, after = results.before, results.after
    lines = [f"{results.source}: {results.n_points} points at {results.n_angles} joint angles, held out one angle at a time"]
    lines += _outcome_lines(results, "angles", "the two-step model")
    lines += [
        "",
        f"held-out gain: ΔELPD {results.gain.delta_elpd:.1f} ± {results.gain.se:.1f} nats over {results.n_angles} angles; "
        f"residual rms per coordinate: lever {before['residual_rms_lever_mm']:.3f} -> {after['residual_rms_lever_mm']:.3f} mm, "
        f"cylinder {before['residual_rms_cylinder_mm']:.3f} -> {after['residual_rms_cylinder_mm']:.3f} mm",
        f"rule: a cause is named when ΔELPD > {results.rule['z']:g} SE and > {results.rule['floor_nats']:g} nats; "
        f"with {results.n_angles} held-out angles the SE itself is uncertain by about "
        f"{100 / (2 * (results.n_angles - 1)) ** 0.5:.0f} %",
    ]
    return "\n".join(lines)


def _text(results, figures: list[str]) -> str:
    from bayescal.reports.next_steps import critique_next_steps

    before, after = results.before, results.after
    lines = [f"{results.source}: {results.n_equations} equations in {results.n_configs} configurations"]
    lines += _outcome_lines(results, "configurations", "the classical model")
    if results.negligible:
        lines[1] += f" ({', '.join(results.negligible)} detectable but too small to matter at the test pose)"
    lines += [
        "",
        f"held-out gain: ΔELPD {results.gain.delta_elpd:.1f} ± {results.gain.se:.1f} nats; residual rms "
        f"{before['residual_rms_mm'] * 1000:.1f} -> {after['residual_rms_mm'] * 1000:.1f} μm; position error rms "
        f"{before['position_error_rms_mm'] * 1000:.1f} -> {after['position_error_rms_mm'] * 1000:.1f} μm",
        f"test pose: the classical model's prediction differs from the extended one's by "
        f"{results.test_pose['classical_error_mm'] * 1000:.1f} μm",
        f"rule: a cause is named when ΔELPD > {results.rule['z']:g} SE and > {results.rule['floor_nats']:g} nats, "
        f"or > {results.rule['decisive_nats']:g} nats and > {results.rule['decisive_z']:g} SE",
    ]
    for cause, entry in results.importance.items():
        before, after = (1000 * v for v in entry["residual_rms_mm"])
        lines.append(
            f"{cause}: residual rms {before:.1f} -> {after:.1f} μm, test pose moved {1000 * entry['test_pose_change_mm']:.1f} μm "
            f"(its sd {1000 * entry['test_pose_sd_mm']:.1f} μm)"
            + ("" if entry["matters"] else ": detectable but too small to matter")
        )
    from bayescal.critique.extensions import CATALOGUE

    plannable = {name for name, e in CATALOGUE.items() if e.physical and not e.robust}
    for kind, pairs in (("tied with", results.tied_with), ("contested by", results.contested_by)):
        for cause, others in pairs.items():
            lines.append(f"{cause} {kind} {', '.join(others)}")
            # the plan that separates exactly that pair (docs/critique.md, The experiment that resolves a tie)
            lines += [
                f"  to separate them: bayescal plan --config CELL.toml --criterion discriminate --between {cause},{other} "
                f"--campaign {results.source} -o PLAN.csv"
                for other in others
                if {cause, other} <= plannable
            ]
    drift = results.drift
    if "source" in drift:
        lines += nests_lines(drift)
    elif drift.get("testable"):
        lines.append(
            f"drift from {drift['evidence']}: {1000 * drift['deflection_rms_mm']:.1f} μm rms in the deflections"
            + (" (removed)" if "drift" in results.causes else "")
        )
    elif drift:
        lines.append(f"drift: not testable on this campaign: {drift['evidence']}")
    if figures:
        lines.append(f"figures: {', '.join(figures)}")
    misfit = getattr(results, "lack_of_fit", None)
    advice = critique_next_steps(
        list(results.causes), misfit is not None and misfit.significant(), results.test_pose["classical_error_mm"], results.negligible
    )
    lines += ["", *textwrap.wrap(advice, width=100)]
    return "\n".join(lines)
