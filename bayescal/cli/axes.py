"""``bayescal axes``: the joint axes and the robot's frames in the tracker frame, from joint sweeps."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bayescal.output import guard_outputs, write_atomically
from bayescal.units import MM

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
    parser.add_argument("--exclude-joint", type=int, action="append", default=[], metavar="J",
                        help="leave joint J's sweep out (1-based; repeat for more)")
    parser.add_argument("--exclude-marker", action="append", default=[], metavar="NAME",
                        help="leave the reflector NAME out of every sweep (repeat for more)")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    """Register and return the JSON payload and a readable table."""
    from bayescal.cell.config import load_cell
    from dataclasses import replace

    import numpy as np

    from bayescal.registration import read_sweeps, register
    from bayescal.critique.sweeps import critique_sweeps
    from bayescal.registration.register import exclude

    from ._command import options_for

    cell = load_cell(args.config)
    # Guarded once the cell is read: the files it points to (URDF, reference table) are then among the inputs.
    guard_outputs({"the sweeps": args.sweeps, "the config": args.config}, {"-o": args.output})
    sweeps = read_sweeps(args.sweeps, cell.robot)
    with options_for({"joints": "--exclude-joint", "markers": "--exclude-marker"}):
        registration = register(sweeps, cell, rng=args.seed, exclude_joints=[j - 1 for j in args.exclude_joint],
                                exclude_markers=args.exclude_marker)
    payload, text = registration.to_json(), _registration_text(registration)
    if args.critique:
        fitted = exclude(sweeps, [j - 1 for j in args.exclude_joint] + list(registration.left_out), args.exclude_marker)
        critique = critique_sweeps(fitted, replace(cell.tracker, position=np.zeros(3)))
        payload["critique"] = critique.to_json()
        text += "\n\n" + _critique_text(critique)
    if args.output:
        write_atomically("-o", args.output, lambda path: Path(path).write_text(json.dumps(payload, indent=2), encoding="utf-8"))
        text += f"\nregistration saved to {args.output}"
    return CommandOutput(payload, text)


def _registration_text(registration) -> str:
    """A readable table of the axes and frames of a :class:`~bayescal.registration.register.Registration`,
    what was left out or is missing, and a warning for each joint whose arcs scatter beyond the tracker's law."""
    lines = [f"Joint axes in the tracker frame from {registration.source}", "",
             f"{'joint':>5} {'direction':>32} {'sd mrad':>9} {'±3σ mrad':>9} {'point mm':>32} {'sd mm':>9} {'±3σ mm':>9} "
             f"{'dof':>5} {'rms mm':>8} {'χ²/dof':>8} {'excess':>7}"]
    for j, fit in registration.axes.items():
        direction = " ".join(f"{v:10.6f}" for v in fit.direction)
        point = " ".join(f"{v / MM:10.2f}" for v in fit.point)
        dof, half = min(fit.direction_dof, fit.point_dof), fit.half_widths()
        lines.append(f"{j + 1:>5} {direction:>32} {fit.direction_sd * 1e3:9.4g} {half['direction_mrad']['3']:9.4g} {point:>32} "
                     f"{fit.point_sd / MM:9.4g} {half['point_mm']['3']:9.4g} {dof:5.2g} {fit.residual_rms / MM:8.4f} "
                     f"{fit.chi2_per_dof:8.3g} {fit.excess:7.3g}")
    lines.append("(sd: clustered by swept angle; ±3σ: the half-width of the interval with the "
                 "normal's ±3σ coverage, 99.7 %, from Student's t with the sd's degrees of freedom, dof, the smaller of "
                 "direction's and point's; χ²/dof against the tracker's law; excess: the noise learned from the arcs over that law)")
    excluded = registration.excluded
    if excluded["joints"] or excluded["markers"]:
        left = [f"the sweep{'s' if len(excluded['joints']) > 1 else ''} of joint{'s' if len(excluded['joints']) > 1 else ''} "
                f"{', '.join(map(str, excluded['joints']))}"] if excluded["joints"] else []
        left += [f"reflector{'s' if len(excluded['markers']) > 1 else ''} {', '.join(excluded['markers'])}"] if excluded["markers"] else []
        lines.append(f"left out as asked: {' and '.join(left)}")
    beyond = {j: fit for j, fit in registration.axes.items() if fit.beyond_tracker}
    if beyond:
        scatters = [fit.scatter for fit in beyond.values()]
        size = f"{min(scatters):.2g}" if len(beyond) == 1 else f"{min(scatters):.2g}-{max(scatters):.2g}"
        lines.append(f"warning: the arcs of joint{'s' if len(beyond) > 1 else ''} {', '.join(str(j + 1) for j in beyond)} "
                     f"scatter {size} times the tracker's law, beyond its chance (χ²/dof above): the cell adds error its "
                     "tracker's datasheet does not (the reflectors' seating, the joint's wobble and transmission error, air); "
                     "the sds above follow the scatter, clustered by swept angle, and so do the frames' built from them; "
                     "--critique says whether an effect of the joint explains it")
    for j, why in registration.left_out.items():
        lines.append(f"joint {j + 1}: no axis: the sweep {why}")
    if registration.missing:
        lines.append(registration.missing)
    for name, frame in registration.frames.items():
        data = frame.to_json()
        lines += ["", f"{name} frame in the tracker frame (p_tracker = R p + t):"]
        lines += [" ".join(f"{v:10.6f}" for v in row) for row in frame.rotation]
        lines.append("t [mm] " + " ".join(f"{v:10.3f}" for v in data["translation_mm"])
                     + "   sd [mm] " + " ".join(f"{v:.4g}" for v in data["translation_sd_mm"]))
        lines.append("rotation sd [mrad] " + " ".join(f"{v:.4g}" for v in data["rotation_sd_mrad"]))
        if "rotation_dof" in data:
            lines.append("±3σ (99.7 %, Student's t) [mrad] " + " ".join(f"{v:.4g}" for v in data["rotation_half_width_mrad"]["3"])
                         + "   [mm] " + " ".join(f"{v:.4g}" for v in data["translation_half_width_mm"]["3"]))
        lines.append(f"not fixed by the sweeps: {frame.from_nominal}")
    return "\n".join(lines)


def _critique_text(critique) -> str:
    """The sweep critique's evidence per joint and candidate, and what each named cause gains."""
    lines = [f"sweep critique (held out one angle at a time): {critique.verdict}"]
    for j, c in critique.joints.items():
        for name, row in c.evidence.iterrows():
            lines.append(f"  joint {j + 1} {name:<14} ΔELPD {row['delta_elpd']:8.1f} ± {row['se']:6.1f} nats  "
                         f"{row['estimate']:10.4g} ± {row['estimate_sd']:.2g} {row['unit']}{'  NAMED' if row['named'] else ''}")
        if c.causes:
            best = c.evidence.loc[c.causes[0]]
            lines.append(f"  joint {j + 1}: {c.causes[0]} predicts held-out angles better: rms "
                         f"{best['rms_circle_mm']:.4f} -> {best['rms_candidate_mm']:.4f} mm")
    return "\n".join(lines)
