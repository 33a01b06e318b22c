"""``bayescal axes``: the joint axes and the robot's frames in the tracker frame, from joint sweeps."""

from __future__ import annotations

import argparse

from bayescal.output import guard_outputs, write_atomically

from ._command import CommandOutput, add_common_options


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``bayescal axes``."""
    parser = subparsers.add_parser(
        "axes",
        help="register the tracker to the robot from joint sweeps",
        description=(
            "Fit each swept joint's axis in the tracker frame (all its reflectors together, known angles, the cell's "
            "tracker noise) with its uncertainty, then the paper's frame and the URDF base frame from axes 1 and 2."
        ),
    )
    parser.add_argument("sweeps", help="CSV with columns joint, q1_deg … qn_deg, marker, x_mm, y_mm, z_mm (tracker frame)")
    parser.add_argument("--config", required=True, help="cell TOML file: robot URDF and tracker noise")
    parser.add_argument("-o", "--output", metavar="REGISTRATION.json", help="write the registration as JSON")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    """Register and return the JSON payload and a readable table."""
    from bayescal.cell.config import load_cell
    from bayescal.registration import read_sweeps, register

    guard_outputs({"the sweeps": args.sweeps, "the config": args.config}, {"-o": args.output})
    cell = load_cell(args.config)
    registration = register(read_sweeps(args.sweeps), cell, rng=args.seed)
    if args.output:
        write_atomically("-o", args.output, registration.save)
    text = registration.text() + (f"\nregistration saved to {args.output}" if args.output else "")
    return CommandOutput(registration.to_json(), text)
