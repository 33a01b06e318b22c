"""``bayescal export``: the cell's URDF with a calibration's identified compliances, for the tools that read URDF."""

from __future__ import annotations

import argparse

from ._command import CommandOutput, add_common_options, write_atomically

__all__ = ["add_parser", "run"]


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "export",
        help="write the cell's URDF with a calibration's compliances",
        description=(
            "Write the cell's URDF with the calibration's joint compliances (mean and sd, whether identified) and "
            "compensator in <bayescal:...> elements that URDF readers ignore, and, for a kinematic calibration "
            "(`bayescal kinematics`), its identified joint placements (docs/controllers.md)."
        ),
    )
    parser.add_argument("--calibration", required=True, metavar="CALIBRATION.nc", help="posterior from `bayescal calibrate --posterior`")
    parser.add_argument("--config", required=True, metavar="CELL.toml", help="the cell file of the calibration")
    parser.add_argument("-o", "--output", required=True, metavar="ROBOT.urdf", help="the calibrated URDF to write")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from pathlib import Path

    from bayescal.cell.cellfile import is_points_cell
    from bayescal.output import guard_outputs, record_read

    inputs = {"the calibration": args.calibration, "the config": args.config}
    guard_outputs(inputs, {"-o": args.output})
    if is_points_cell(args.config):
        from bayescal.controllers.urdf import kinematic_urdf
        from bayescal.kinematics import load_points_cell
        from bayescal.kinematics.saved import load_kinematic_calibration

        cell = load_points_cell(args.config)
        urdf_path = cell.tree.source
        guard_outputs(inputs | {"the robot URDF": urdf_path}, {"-o": args.output})
        results = load_kinematic_calibration(args.calibration, cell)
        record_read(urdf_path, "the robot URDF")
        # Read as Latin-1 and written back so: every byte of the cell's file is kept, whatever its encoding.
        urdf = kinematic_urdf(Path(urdf_path).read_text(encoding="latin-1"), results, source=Path(args.calibration).name)
        what = f"the joint placements and compliances of the kinematic calibration {args.calibration}"
        payload = {"urdf": str(args.output), "calibration": "kinematic", "corrected_joints": [cell.tree.names[j] for j in results.model.corrected]}
    else:
        from bayescal.cell.config import load_cell
        from bayescal.compensation import load_calibration
        from bayescal.controllers.urdf import calibrated_urdf

        cell = load_cell(args.config)
        urdf_path = cell.robot.source
        guard_outputs(inputs | {"the robot URDF": urdf_path}, {"-o": args.output})
        calibration = load_calibration(args.calibration, cell)
        record_read(urdf_path, "the robot URDF")
        urdf = calibrated_urdf(Path(urdf_path).read_text(encoding="latin-1"), cell.robot, calibration, source=Path(args.calibration).name)
        what = f"the compliances of {calibration.n_draws} draws of {args.calibration}"
        payload = {"urdf": str(args.output), "calibration": "elastostatic", "joints": list(cell.robot.joint_names),
                   "draws": calibration.n_draws, "unidentified": list(calibration.unidentified)}
    write_atomically("-o", args.output, lambda temporary: temporary.write_bytes(urdf.encode("latin-1")))
    return CommandOutput(payload=payload, text=f"wrote {args.output}: {urdf_path}'s robot with {what}")
