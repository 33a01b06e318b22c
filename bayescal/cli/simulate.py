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
    parser.add_argument(
        "--kinematic-errors",
        type=_scale_text,
        default=0.0,
        metavar="SCALE",
        help="give the twin's robot kinematic errors drawn from the seed, SCALE times their realistic size (1: joint "
        "offsets and twists 0.05 deg, lengths 0.5 mm, sd per component); default 0, the URDF's geometry",
    )
    parser.add_argument(
        "--positions",
        metavar="POSITIONS.csv",
        help="also write the first repeat's unloaded readings as a positions file for `bayescal kinematics`",
    )
    parser.add_argument(
        "--drift", type=_scale_text, metavar="MM_PER_H",
        help="the tracker's frame drifts at this rate (mm/h; bayescal.twin.drift): a steady translation and turn and a "
        "random walk; the campaign then carries its reading times t0_s, t1_s",
    )
    parser.add_argument(
        "--order", choices=("together", "passes"), default=None,
        help="together: a configuration's repeats one after another; passes: the plan measured once per repeat, so "
        "that each configuration's repeats lie a pass apart in time (the campaign then carries its times); default: "
        "as the plan's in_passes column says (`bayescal plan --order passes`), together without it",
    )
    parser.add_argument(
        "--nests", metavar="NESTS.csv",
        help="also write the readings of the twin's reference nests (nest, t_s, x_mm, y_mm, z_mm), read before the "
        "first configuration, and while each load is hung and after it is removed at the configurations the plan's "
        "read_nests column marks (all without it); the campaign then carries its times",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def _scale_text(text: str) -> float:
    """A plain decimal number >= 0."""
    from bayescal.tables import is_plain_number

    if not is_plain_number(text) or float(text) < 0:
        raise argparse.ArgumentTypeError(f"expected a plain decimal number >= 0, got '{text}'")
    return float(text)


def _effect_text(text: str) -> str:
    """``NAME`` or ``NAME=MAGNITUDE`` with a plain decimal magnitude; the twin checks the name and the range."""
    from bayescal.tables import is_plain_number

    _, equals, value = text.partition("=")
    if equals and not is_plain_number(value):
        raise argparse.ArgumentTypeError(f"expected NAME=MAGNITUDE with a plain decimal number, got '{text}'")
    return text


def _kinematic_errors(args: argparse.Namespace, robot):
    """The errors ``--kinematic-errors`` gives the twin's robot, or None: drawn from a stream of their own, so that
    the same seed reads the same noise with and without them."""
    if args.kinematic_errors == 0:
        return None
    import numpy as np

    from bayescal.twin.kinematic_errors import KINEMATIC_ERRORS_STREAM, KinematicErrors

    return KinematicErrors.draw(robot, np.random.default_rng([args.seed, KINEMATIC_ERRORS_STREAM]), scale=args.kinematic_errors)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.errors import InputError
    from bayescal.twin.effects import parse_effect

    inputs = {"the plan": args.plan, "the config": args.config}
    check_output("-o", args.output, inputs)
    if args.positions is not None:
        check_output("--positions", args.positions, inputs | {"the campaign": args.output})
    if args.nests is not None:
        check_output("--nests", args.nests, inputs | {"the campaign": args.output, "the --positions file": args.positions})
    effects = [parse_effect(text, source="--effect") for text in args.effect]
    names = [effect.name for effect in effects]
    if len(set(names)) < len(names):
        repeated = next(name for name in names if names.count(name) > 1)
        raise InputError(f"effect '{repeated}' is given more than once", source="--effect")
    cell = load_cell(args.config)
    check_output("-o", args.output, inputs | {"the robot URDF": cell.robot.source})
    plan = read_plan(args.plan, cell.robot, max_load_kg=cell.max_force / cell.gravity, loading=cell.loading)
    errors = _kinematic_errors(args, cell.robot)
    twin, campaign, nests = _simulated(args, cell, plan, effects, errors)
    planted = [effect.describe() for effect in twin.effects] + ([] if twin.drift is None else [twin.drift.describe()])
    comments = [
        f"simulated by bayescal simulate --plan {args.plan} --config {args.config} --repeats {args.repeats} --seed {args.seed}",
        f"effects: {', '.join(planted) if planted else 'none'}; compensator {'on' if twin.arm.compensator else 'off'}",
        "wrench at the flange origin in base axes; positions in the base frame, 0 unloaded, 1 loaded",
    ]
    if errors is not None:
        comments += [f"kinematic errors (scale {args.kinematic_errors:g}), per joint tx_mm ty_mm tz_mm rx_deg ry_deg rz_deg "
                     "in the frame where its axis is z:"] + [f"  {name}: " + " ".join(f"{v:+.4f}" for v in row) for name, row in errors.summary().iterrows()]
    _write(args, cell, campaign, nests, comments)
    return _summary(args, cell, plan, twin, campaign, nests, errors, planted)


def _simulated(args: argparse.Namespace, cell, plan, effects: list, errors):
    """The twin (with the kinematic errors, effects and drift asked for), its campaign and, when asked, its nest readings."""
    import numpy as np

    from bayescal.cell.nests import read_nest_column
    from bayescal.cell.plan import read_passes
    from bayescal.errors import InputError
    from bayescal.twin.drift import TrackerDrift
    from bayescal.twin.simulator import DigitalTwin

    if errors is not None:
        # imported with kinematic errors alone: it brings the kinematics package and pandas
        from bayescal.twin.kinematic_errors import with_kinematic_errors

        cell = with_kinematic_errors(cell, errors)
    drift = None if args.drift is None else TrackerDrift(args.drift)
    passes = args.order == "passes" if args.order is not None else read_passes(args.plan)
    twin = DigitalTwin(cell, effects, drift=drift, passes=passes)
    try:
        if args.nests is None and not passes:
            return twin, twin.simulate(plan, args.repeats, np.random.default_rng(args.seed)), None
        campaign, nests = twin.simulate_with_nests(plan, args.repeats, np.random.default_rng(args.seed), read_nest_column(args.plan))
        return twin, campaign, nests if args.nests is not None else None
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


def _write(args: argparse.Namespace, cell, campaign, nests, comments: list[str]) -> None:
    """The campaign, and the positions and nests files when asked for, each written whole or not at all."""
    from functools import partial

    from bayescal.cell.campaign import write_campaign

    write_atomically("-o", args.output, partial(write_campaign, campaign, comments=comments))
    if args.positions is not None:
        from bayescal.kinematics.from_campaign import write_positions

        write_atomically("--positions", args.positions, partial(write_positions, campaign=campaign, columns=cell.robot.position_columns,
                                                                comments=tuple(comments[:1] + comments[3:])))
    if nests is not None:
        notes = (comments[0] + f" --nests {args.nests}", "reference nests fixed in the base frame; t_s on the campaign's clock")
        write_atomically("--nests", args.nests, partial(nests.write, comments=notes))


def _summary(args: argparse.Namespace, cell, plan, twin, campaign, nests, errors, planted: list[str]) -> CommandOutput:
    """What was written, as JSON and as text."""
    import numpy as np

    from bayescal.units import MM, UM

    low, high = (sd / UM for sd in cell.tracker.sigma_range(campaign.p0, campaign.p1))
    deflection = float(np.linalg.norm(campaign.displacement, axis=1).max() / MM)
    drift = twin.drift
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
        "kinematic_errors": None if errors is None else {"scale": args.kinematic_errors, "joints": errors.summary().to_dict(orient="index")},
        "positions": args.positions,
        "drift_mm_per_h": None if drift is None else drift.magnitude,
        "nests": None if nests is None else {"output": args.nests, "readings": len(nests), "nests": len(set(nests.name))},
    }
    text = "\n".join(
        [
            f"wrote {args.output}: {len(campaign)} rows = {len(plan)} configurations x {args.repeats} repeats x "
            f"{len(twin.marker_names)} markers, {campaign.n_equations} equations",
            f"compensator: {'on' if twin.arm.compensator else 'off'}; effects: {', '.join(planted) if planted else 'none'}",
            f"tracker noise sd per coordinate: {low:.1f} to {high:.1f} um",
            f"largest marker deflection: {deflection:.3f} mm",
        ]
        + ([] if errors is None else [f"kinematic errors: scale {args.kinematic_errors:g} of their realistic size (listed in the file's header)"])
        + ([] if args.positions is None else [f"wrote {args.positions}: the first repeat's unloaded readings, for bayescal kinematics"])
        + ([] if nests is None else [f"wrote {args.nests}: {len(nests)} readings of {len(set(nests.name))} reference nests"])
    )
    return CommandOutput(payload=payload, text=text)
