"""``bayescal predict``: marker positions of configurations from a kinematic calibration, with predictive sds."""

from __future__ import annotations

import argparse

from ._command import CommandOutput, add_common_options

__all__ = ["add_parser", "run"]

DECIMALS = 4
"""Decimals of the written positions and sds (mm): 0.1 μm, far below any tracker's noise."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "predict",
        help="predict marker positions of configurations from a kinematic calibration",
        description=(
            "Read configurations (q1_deg..qn_deg, marker) and write the same rows, in the same order, with the predicted "
            "position x_mm, y_mm, z_mm in the tracker frame and its predictive sd x_sd_mm, y_sd_mm, z_sd_mm "
            "(the posterior's, the tracker's noise and the learned model error)."
        ),
    )
    parser.add_argument("configurations", metavar="CONFIGURATIONS.csv", help="q1_deg..qn_deg, marker (other columns are ignored)")
    parser.add_argument("--calibration", required=True, metavar="CALIBRATION.nc", help="from `bayescal kinematics -o`")
    parser.add_argument("--config", required=True, metavar="CELL.toml", help="the cell of the calibration")
    parser.add_argument("-o", "--output", required=True, metavar="PREDICTED.csv", help="the predicted positions to write")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    import numpy as np
    import pandas as pd

    from bayescal.kinematics import load_kinematic_calibration, load_points_cell, read_positions
    from bayescal.output import guard_outputs, write_atomically

    inputs = {"the configurations": args.configurations, "the calibration": args.calibration, "the config": args.config}
    guard_outputs(inputs, files={"-o": args.output})
    cell = load_points_cell(args.config)
    guard_outputs(inputs | {"the robot URDF": cell.tree.source}, files={"-o": args.output})
    wanted = read_positions(args.configurations, cell, measured=False)
    results = load_kinematic_calibration(args.calibration, cell)
    mean, covariance = results.predict(wanted.joints)
    sd = np.sqrt(np.diagonal(covariance, axis1=-2, axis2=-1))
    order = np.argsort(wanted.rows.reshape(-1))
    angles = np.repeat(wanted.joints, len(cell.markers), axis=0)[order] * 180 / np.pi
    table = pd.DataFrame(angles, columns=list(cell.joint_columns))
    table["marker"] = np.tile(cell.marker_names, len(wanted))[order]
    for axis, column in enumerate("xyz"):
        table[f"{column}_mm"] = (mean[..., axis].reshape(-1) * 1e3)[order]
    for axis, column in enumerate("xyz"):
        table[f"{column}_sd_mm"] = (sd[..., axis].reshape(-1) * 1e3)[order]
    write_atomically("-o", args.output, lambda path: table.to_csv(path, index=False, float_format=f"%.{DECIMALS}f"))
    largest = float(sd.max() * 1e3)
    payload = {"rows": len(table), "largest_sd_mm": largest, "output": args.output}
    return CommandOutput(payload=payload, text=f"predicted {len(table)} marker positions (largest sd {largest:.3f} mm); wrote {args.output}")
