"""``bayescal compensate``: compensated joint targets of a machining program and the error each pose keeps."""

from __future__ import annotations

import argparse

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically

__all__ = ["add_parser", "run"]


def _millimetres(text: str) -> float:
    """A positive length in mm written as a plain decimal number."""
    from bayescal.tables import is_plain_number

    if not is_plain_number(text) or float(text) <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive length in mm, got '{text}'")
    return float(text)


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compensate",
        help="compensate a machining program's compliance errors with a calibration",
        description=(
            "Correct the joint targets of a machining program so that the tool, loaded by each row's process wrench, "
            "lands where the unloaded tool is at the programmed joints, and give the error each pose still carries "
            "over the calibration's posterior (rms, 95 %%, 99.73 %%)."
        ),
    )
    parser.add_argument("program", metavar="PROGRAM.csv", help="q1_deg..qn_deg, fx_N..mz_Nm (about the tool point), optional tcp_x_mm..tcp_z_mm")
    parser.add_argument("--calibration", required=True, metavar="CALIBRATION.nc", help="posterior from `bayescal calibrate --posterior`")
    parser.add_argument("--config", required=True, metavar="CELL.toml", help="the cell file of the calibration")
    parser.add_argument("-o", "--output", required=True, metavar="COMPENSATED.csv", help="compensated program to write")
    parser.add_argument("--tolerance-mm", type=_millimetres, help="flag poses whose 99.73 %% error exceeds this length (mm)")
    parser.add_argument(
        "--decimals",
        type=whole_number(1, "decimals of the written targets"),
        help="fixed decimals of the compensated targets (deg or mm) and lengths (mm) written, as the controller takes them "
        "(default: as many as KUKA KRL and ABB RAPID take, docs/compensation.md)",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from functools import partial

    from bayescal.cell.config import load_cell
    from bayescal.compensation import compensate_program, load_calibration, read_program
    from bayescal.units import MM

    inputs = {"the program": args.program, "the calibration": args.calibration, "the config": args.config}
    check_output("-o", args.output, inputs)
    cell = load_cell(args.config)
    check_output("-o", args.output, inputs | {"the robot URDF": cell.robot.source})
    program = read_program(args.program, cell)
    calibration = load_calibration(args.calibration, cell)
    tolerance = None if args.tolerance_mm is None else args.tolerance_mm * MM
    results = compensate_program(program, calibration, cell, tolerance=tolerance)
    decimals = {} if args.decimals is None else {"decimals": args.decimals}
    write_atomically("-o", args.output, partial(results.save, **decimals))
    return CommandOutput(payload=results.to_json(), text=results.text() + f"\nwrote {args.output}")
