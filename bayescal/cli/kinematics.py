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
    parser.add_argument("--model", help="the rung of the ladder to fit (docs/kinematics.md lists them; default full, geometry with --elastic)")
    parser.add_argument("-o", "--output", metavar="CALIBRATION.nc", help="write the posterior (NetCDF) for `bayescal predict` "
                        "(with --elastic: and the deflection model, naming --elastic-config, which must stay unchanged)")
    parser.add_argument("--elastic", metavar="POSTERIOR.nc",
                        help="take the arm's deflection from an elastostatic calibration (`bayescal calibrate --posterior`), "
                        "its spring and masses refined, instead of the rung's own masses (a rigid --model; default geometry)")
    parser.add_argument("--elastic-config", metavar="CELL.toml", help="the elastostatic cell of --elastic (robot, compensator, tool)")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.errors import InputError
    from bayescal.kinematics import EXTENSIONS, RUNGS, KinematicCalibration, load_points_cell, read_positions
    from bayescal.output import guard_outputs, write_atomically

    rung = args.model or ("full" if args.elastic is None else "geometry")
    if rung not in RUNGS + EXTENSIONS:
        raise InputError(f"expected one of {', '.join(RUNGS + EXTENSIONS)}, got '{rung}'", source="--model")
    if (args.elastic is None) != (args.elastic_config is None):
        raise InputError("give --elastic and --elastic-config together", source="--elastic" if args.elastic is None else "--elastic-config")
    inputs = {"the positions": args.positions, "the config": args.config}
    if args.elastic is not None:
        inputs |= {"the elastostatic calibration": args.elastic, "the elastostatic cell": args.elastic_config}
    guard_outputs(inputs, files={"-o": args.output})
    cell = load_points_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.tree.source}, files={"-o": args.output})
    positions = read_positions(args.positions, cell)
    if args.elastic is None:
        results = KinematicCalibration(cell, rung).fit(positions)
    else:
        results = _elastic_fit(args, cell, positions, rung)
    if args.output is not None:
        write_atomically("-o", args.output, results.save)
    payload = results.to_json()
    text = results.document().as_text() + (f"\nwrote {args.output}" if args.output else "")
    return CommandOutput(payload=payload, text=text)


def _elastic_fit(args: argparse.Namespace, cell, positions, rung: str):
    """The rigid rung with the deflection of the elastostatic calibration ``--elastic`` (:mod:`bayescal.kinematics.elastic`)."""
    from bayescal.cell.config import load_cell
    from bayescal.compensation.calibration import load_calibration
    from bayescal.errors import InputError
    from bayescal.kinematics.elastic import RIGID_RUNGS, ElasticKinematicCalibration

    if rung not in RIGID_RUNGS:
        raise InputError(f"with --elastic the rung is rigid (the elastostatic calibration gives the deflection): one of "
                         f"{', '.join(RIGID_RUNGS)}, got '{rung}'", source="--model")
    elastic_cell = load_cell(args.elastic_config)
    calibration = load_calibration(args.elastic, elastic_cell)
    return ElasticKinematicCalibration.from_calibration(elastic_cell, cell, calibration, rung).fit(positions)
