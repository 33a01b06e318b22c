"""``bayescal compensate``: compensated targets of a machining program (CSV, KRL or RAPID) and the error each pose keeps."""

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


def _wrench(text: str) -> list[float]:
    """Six plain decimal numbers ``FX,FY,FZ,MX,MY,MZ`` (N, N·m)."""
    from bayescal.tables import is_plain_number

    parts = [part.strip() for part in text.split(",")]
    if len(parts) != 6 or not all(is_plain_number(part) for part in parts):
        raise argparse.ArgumentTypeError(f"expected six numbers FX,FY,FZ,MX,MY,MZ in N and N·m, got '{text}'")
    return [float(part) for part in parts]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "compensate",
        help="compensate a machining program's compliance errors with a calibration",
        description=(
            "Correct the joint targets of a machining program so that the tool, loaded by each row's process wrench, "
            "lands where the unloaded tool is at the programmed joints, and give the error each pose still carries "
            "over the calibration's posterior (rms, 95 %%, 99.73 %%).  A KUKA KRL (.src with its .dat) or ABB RAPID (.mod) "
            "program is read and written in its own language, its Cartesian targets solved in their configuration."
        ),
    )
    parser.add_argument(
        "program",
        metavar="PROGRAM",
        help="a CSV of q1_deg..qn_deg, fx_N..mz_Nm (about the tool point), optional tcp_x_mm..tcp_z_mm; "
        "or a KRL .src (with its .dat) or a RAPID .mod (docs/controllers.md)",
    )
    parser.add_argument("--calibration", required=True, metavar="CALIBRATION.nc", help="posterior from `bayescal calibrate --posterior`")
    parser.add_argument("--config", required=True, metavar="CELL.toml", help="the cell file of the calibration")
    parser.add_argument(
        "-o", "--output", required=True, metavar="COMPENSATED", help="compensated program to write, in the program's format (OUT.src also writes OUT.dat)"
    )
    wrench = parser.add_mutually_exclusive_group()
    wrench.add_argument(
        "--wrenches", metavar="WRENCHES.csv",
        help="a KRL or RAPID program's process wrench per target: columns target, fx_N, fy_N, fz_N, mx_Nm, my_Nm, mz_Nm "
        "(robot base axes, moment about the tool point)",
    )
    wrench.add_argument(
        "--wrench", type=_wrench, metavar="FX,FY,FZ,MX,MY,MZ",
        help="one process wrench for every target of a KRL or RAPID program (N and N·m, robot base axes, about the tool point)",
    )
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
    from pathlib import Path

    if Path(args.program).suffix.lower() in (".src", ".mod"):
        return _run_controller(args)
    if args.wrenches is not None or args.wrench is not None:
        from bayescal.errors import InputError

        raise InputError("a CSV program gives each row's wrench in its fx_N..mz_Nm columns", source="--wrenches" if args.wrenches else "--wrench")
    return _run_csv(args)


def _run_csv(args: argparse.Namespace) -> CommandOutput:
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
    return CommandOutput(payload=results.to_json(), text=results.document().as_text() + f"\nwrote {args.output}")


def _run_controller(args: argparse.Namespace) -> CommandOutput:
    from bayescal.cell.config import load_cell
    from bayescal.compensation import load_calibration
    from bayescal.compensation.results import DECIMALS
    from bayescal.controllers.compensate import (
        compensate_controller_program, constant_wrench, output_paths, read_controller_program, read_wrenches,
    )
    from bayescal.errors import InputError
    from bayescal.output import guard_outputs
    from bayescal.units import MM

    from ._command import options_for

    if args.wrenches is None and args.wrench is None:
        raise InputError("a KRL or RAPID program carries no process wrench: give --wrenches WRENCHES.csv or --wrench FX,FY,FZ,MX,MY,MZ", source="--wrench")
    inputs = {"the program": args.program, "the calibration": args.calibration, "the config": args.config, "the wrench file": args.wrenches}
    check_output("-o", args.output, inputs)
    cell = load_cell(args.config)
    program = read_controller_program(args.program)
    with options_for({"output": "-o"}):
        paths = output_paths(args.output, program)
    inputs |= {f"the program's {role} file": path for role, path in program.paths.items()} | {"the robot URDF": cell.robot.source}
    guard_outputs(inputs, {f"-o ({role})": path for role, path in paths.items()})
    if args.wrenches is not None:
        wrench = read_wrenches(args.wrenches, program, cell)
    else:
        with options_for({"wrench": "--wrench"}):
            wrench = constant_wrench(args.wrench, program, cell)
    calibration = load_calibration(args.calibration, cell)
    tolerance = None if args.tolerance_mm is None else args.tolerance_mm * MM
    compensated = compensate_controller_program(program, wrench, calibration, cell, tolerance=tolerance)
    texts = compensated.texts(DECIMALS if args.decimals is None else args.decimals)
    for role, path in paths.items():
        write_atomically("-o", path, lambda temporary, text=texts[role]: temporary.write_bytes(text.encode("latin-1")))
    return CommandOutput(payload=compensated.to_json(), text=compensated.document().as_text() + f"\nwrote {', '.join(str(p) for p in paths.values())}")
