"""``bayescal simulate``: write a campaign CSV measured on the digital twin."""

from __future__ import annotations

import argparse

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically

__all__ = ["add_parser", "run"]


class _EffectsHelp(argparse.HelpFormatter):
    """Lists the twin's effects in ``--effect``'s help when the help is shown.

    Building the list imports the twin (and Pinocchio), which the other
    subcommands, whose parsers are built on every run, do not need.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = super()._get_help_string(action) or ""
        if "--effect" in action.option_strings:
            from bayescal.twin.effects import EFFECTS

            text += ": " + "; ".join(f"{name}: {cls.summary} (default {cls.default:g} {cls.unit})" for name, cls in EFFECTS.items())
        return text


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "simulate",
        help="simulate an elastostatic calibration campaign on the digital twin",
        description=(
            "Measure every configuration of a plan unloaded and loaded on the digital twin of a cell, "
            "with laser-tracker noise, and write the campaign CSV."
        ),
        formatter_class=_EffectsHelp,
    )
    parser.add_argument("--plan", required=True, help="plan CSV: q1_deg..q<n>_deg (q<j>_mm for a prismatic joint) and optionally load_kg per configuration")
    parser.add_argument("--config", required=True, help="cell TOML file (robot, stiffness, compensator, tool, tracker)")
    parser.add_argument("--repeats", type=whole_number(1), default=3, help="measurements of each configuration (default 3)")
    parser.add_argument("-o", "--output", required=True, help="campaign CSV to write")
    parser.add_argument(
        "--effect",
        action="append",
        type=_effect_text,
        default=[],
        metavar="NAME[=MAGNITUDE]",
        help="plant an effect, repeatable",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def _effect_text(text: str) -> str:
    """``NAME`` or ``NAME=MAGNITUDE`` with a plain decimal magnitude; the twin checks the name and the range."""
    from bayescal.tables import is_plain_number

    _, equals, value = text.partition("=")
    if equals and not is_plain_number(value):
        raise argparse.ArgumentTypeError(f"expected NAME=MAGNITUDE with a plain decimal number, got '{text}'")
    return text


def run(args: argparse.Namespace) -> CommandOutput:
    from functools import partial

    import numpy as np

    from bayescal.cell.campaign import write_campaign
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.errors import InputError
    from bayescal.twin.effects import parse_effect
    from bayescal.twin.simulator import DigitalTwin
    from bayescal.units import MM, UM

    inputs = {"the plan": args.plan, "the config": args.config}
    check_output("-o", args.output, inputs)
    effects = [parse_effect(text, source="--effect") for text in args.effect]
    names = [effect.name for effect in effects]
    if len(set(names)) < len(names):
        repeated = next(name for name in names if names.count(name) > 1)
        raise InputError(f"effect '{repeated}' is given more than once", source="--effect")
    cell = load_cell(args.config)
    check_output("-o", args.output, inputs | {"the robot URDF": cell.robot.source})
    plan = read_plan(args.plan, cell.robot, max_load_kg=cell.max_force / cell.gravity, loading=cell.loading)
    twin = DigitalTwin(cell, effects)
    try:
        campaign = twin.simulate(plan, args.repeats, np.random.default_rng(args.seed))
    except InputError as error:
        if not effects:
            raise
        # The plan line is where the twin failed; the planted effect is the likelier cause.
        planted = ", ".join(effect.describe() for effect in effects)
        raise InputError(
            f"{error.what}, with the effects {planted}: is an --effect magnitude too large?",
            source=error.source,
            line=error.line,
            column=error.column,
        ) from None

    planted = [effect.describe() for effect in twin.effects]
    comments = [
        f"simulated by bayescal simulate --plan {args.plan} --config {args.config} --repeats {args.repeats} --seed {args.seed}",
        f"effects: {', '.join(planted) if planted else 'none'}; compensator {'on' if twin.arm.compensator else 'off'}",
        "wrench at the flange origin in base axes; positions in the base frame, 0 unloaded, 1 loaded",
    ]
    write_atomically("-o", args.output, partial(write_campaign, campaign, comments=comments))

    low, high = (sd / UM for sd in cell.tracker.sigma_range(campaign.p0, campaign.p1))
    deflection = float(np.linalg.norm(campaign.displacement, axis=1).max() / MM)
    payload = {
        "output": args.output,
        "rows": len(campaign),
        "configurations": len(plan),
        "repeats": args.repeats,
        "markers": list(twin.marker_names),
        "equations": campaign.n_equations,
        "compensator": twin.arm.compensator is not None,
        "effects": [{"name": effect.name, "magnitude": effect.magnitude, "unit": effect.unit} for effect in twin.effects],
        "noise_sd_um": {"min": low, "max": high},
        "max_deflection_mm": deflection,
        "seed": args.seed,
    }
    text = "\n".join(
        [
            f"wrote {args.output}: {len(campaign)} rows = {len(plan)} configurations x {args.repeats} repeats x "
            f"{len(twin.marker_names)} markers, {campaign.n_equations} equations",
            f"compensator: {'on' if twin.arm.compensator else 'off'}; effects: {', '.join(planted) if planted else 'none'}",
            f"tracker noise sd per coordinate: {low:.1f} to {high:.1f} um",
            f"largest marker deflection: {deflection:.3f} mm",
        ]
    )
    return CommandOutput(payload=payload, text=text)
