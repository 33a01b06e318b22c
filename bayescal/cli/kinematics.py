"""``bayescal kinematics``: kinematic and self-weight elastic calibration from measured marker positions."""

from __future__ import annotations

import argparse

from ._command import CommandOutput, add_common_options

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "kinematics",
        help="identify a robot's kinematics and self-weight compliance from measured marker positions",
        description=(
            "Identify the robot's base in the tracker frame, its free frames, the markers' places, each joint's placement "
            "correction (θ, d, r, α) and, on the elastic rungs, its joint and transversal compliances with the links' masses, "
            "from marker positions measured in many configurations. Prints each parameter's posterior mean and sd and says "
            "which parameters the data cannot identify, and why."
        ),
    )
    parser.add_argument("positions", metavar="POSITIONS.csv", help="q1_deg..qn_deg (the cell's commanded joints), marker, x_mm, y_mm, z_mm")
    parser.add_argument("--config", required=True, metavar="CELL.toml", help="cell of measured points: URDF, joints, markers, base, priors")
    # Checked in run: the rungs' module imports Pinocchio, which the parser of every command would then pay for.
    parser.add_argument("--model", default="full", help="the rung of the ladder to fit (docs/kinematics.md lists them; default full)")
    parser.add_argument("-o", "--output", metavar="CALIBRATION.nc", help="write the posterior (NetCDF) for `bayescal predict`")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.errors import InputError
    from bayescal.kinematics import RUNGS, KinematicCalibration, load_points_cell, read_positions
    from bayescal.output import guard_outputs, write_atomically

    if args.model not in RUNGS:
        raise InputError(f"expected one of {', '.join(RUNGS)}, got '{args.model}'", source="--model")
    inputs = {"the positions": args.positions, "the config": args.config}
    guard_outputs(inputs, files={"-o": args.output})
    cell = load_points_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.tree.source}, files={"-o": args.output})
    positions = read_positions(args.positions, cell)
    results = KinematicCalibration(cell, args.model).fit(positions)
    if args.output is not None:
        write_atomically("-o", args.output, results.save)
    payload = results.to_json()
    text = _text(results) + (f"\nwrote {args.output}" if args.output else "")
    return CommandOutput(payload=payload, text=text)


def _text(results) -> str:
    d = results.diagnostics()
    table = results.summary()
    lines = [
        f"model '{d['rung']}', {d['parameters']} parameters ({d['identified']} identified by the data), "
        f"{d['configurations']} configurations",
        f"residual error per marker: mean {d['error_mean_mm']:.2f} mm, sd {d['error_sd_mm']:.2f}, max {d['error_max_mm']:.2f} "
        f"(in sample; `bayescal critique` scores it held out)",
        f"model error learned from the data: {d['model_error_sd_mm']:.3f} mm per coordinate, on top of the tracker's noise",
        f"{'parameter':<34}{'unit':>12}{'mean':>12}{'sd':>10}{'prior sd':>10}",
    ]
    for name, row in table.iterrows():
        if row["identified"]:
            lines.append(f"{name:<34}{row['unit']:>12}{row['mean']:>12.4g}{row['sd']:>10.3g}{row['prior_sd']:>10.3g}")
    hidden = results.identifiability()
    if hidden:
        lines.append(f"{len(hidden)} parameters not identifiable by these data (they keep their prior; see --json):")
        for entry in hidden[:8]:
            lines.append(f"  {entry['parameter']}: {entry['why']}")
        if len(hidden) > 8:
            lines.append(f"  … and {len(hidden) - 8} more")
    partly = int((~table["identified"]).sum()) - len(hidden)
    if partly:
        lines.append(f"{partly} more parameters are partly identified (posterior sd 0.5-0.9 of the prior's): see --json")
    return "\n".join(lines)
