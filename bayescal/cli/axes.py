"""``bayescal axes``: the joint axes and the robot's frames in the tracker frame, from joint sweeps."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

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
    parser.add_argument(
        "--critique",
        action="store_true",
        help="also criticise each joint's circle model on held-out angles (angle scale, cyclic transmission error, "
        "axis wobble, tracker range offset); kept in the registration file",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    """Register and return the JSON payload and a readable table."""
    from bayescal.cell.config import load_cell
    from dataclasses import replace

    import numpy as np

    from bayescal.registration import read_sweeps, register
    from bayescal.registration.critique import critique_sweeps

    guard_outputs({"the sweeps": args.sweeps, "the config": args.config}, {"-o": args.output})
    cell = load_cell(args.config)
    sweeps = read_sweeps(args.sweeps)
    registration = register(sweeps, cell, rng=args.seed)
    payload, text = registration.to_json(), registration.text()
    if args.critique:
        critique = critique_sweeps(sweeps, replace(cell.tracker, position=np.zeros(3)))
        payload["critique"] = critique.to_json()
        text += "\n\n" + critique.text()
    if args.output:
        write_atomically("-o", args.output, lambda path: Path(path).write_text(json.dumps(payload, indent=2), encoding="utf-8"))
        text += f"\nregistration saved to {args.output}"
    return CommandOutput(payload, text)
