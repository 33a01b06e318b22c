"""``bayescal calibrate``: joint compliances and compensator spring from a campaign CSV."""

from __future__ import annotations

import argparse
import json
import math
import textwrap

from bayescal.jsonsafe import json_safe

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically
from ._nests import add_nests_option, nests_lines, measured_drift
from ._registered import add_registration_option, read_campaign_in_base, registration_lines

__all__ = ["add_parser", "run"]

MIN_DRAWS = 100
"""Fewest kept draws per chain the command accepts."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "calibrate",
        help="identify joint compliances and the compensator spring from a campaign, with ±3σ intervals",
        description=(
            "Identify the joint compliances k1..kn and the compensator's K_c and s0 from a campaign CSV "
            "(Klimchik et al., eqs 30-35), with posterior ±3σ intervals, the parameters the campaign cannot "
            "identify, and the positioning error left at the config's test pose (eqs 38-39)."
        ),
    )
    parser.add_argument("campaign", help="campaign CSV (bayescal simulate writes one)")
    parser.add_argument("--config", required=True, help="cell TOML file: robot URDF, compensator, tool load point, tracker, test pose")
    parser.add_argument("--model", choices=("exact", "linear"), default="exact", help="deflection model (default exact)")
    parser.add_argument(
        "--sampler", choices=("collapsed", "gibbs", "emcee"), default="collapsed",
        help="posterior sampler (default collapsed: batched proposals, compliances drawn exactly)",
    )
    parser.add_argument("--noise", choices=("axis", "marker"), default="axis", help="unknown noise level per axis or per marker")
    parser.add_argument("--geometry", metavar="POSTERIOR.nc", help="geometry posterior from `bayescal geometry --posterior`")
    parser.add_argument(
        "--kinematics", metavar="KIN.nc",
        help="compute the deflections on the robot geometry this kinematic calibration identified (`bayescal kinematics -o`): "
             "its joint placement corrections, not its base or markers (docs/kinematics.md)",
    )
    parser.add_argument("--posterior", metavar="OUT.nc", help="write the posterior as a NetCDF DataTree")
    parser.add_argument(
        "--draws",
        type=whole_number(MIN_DRAWS, "fewer give no usable R-hat or effective sample size"),
        default=None,
        help=(f"kept draws per chain, at least {MIN_DRAWS}, never extended (default: the sampler's, 600 for collapsed and gibbs, 800 for "
              "emcee, run again up to 3 times while R-hat or ESS fall short: collapsed hands over to gibbs, which doubles its draws)"),
    )
    add_registration_option(parser, "the campaign's positions")
    add_nests_option(parser)
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    import numpy as np

    from bayescal.cell.config import load_cell
    from bayescal.inference.elastostatic import EXTENSIONS, ElastostaticModel
    from bayescal.inference.samplers import elastostatic_sampler
    from bayescal.errors import InputError
    from bayescal.robot.stiffness import EquilibriumError
    from bayescal.compensation.testpose import predict_cell_test_pose

    inputs = {"the campaign": args.campaign, "the config": args.config, "the --geometry posterior": args.geometry,
              "the --registration file": args.registration, "the --nests file": args.nests,
              "the --kinematics calibration": args.kinematics}
    check_output("--posterior", args.posterior, inputs)
    cell = load_cell(args.config)
    cell, identified = _on_identified_geometry(cell, args.kinematics) if args.kinematics else (cell, None)
    check_output("--posterior", args.posterior, inputs | {"the robot URDF": cell.robot.source})
    geometry = _geometry_prior(args, cell) if args.geometry else None
    campaign, cell, transfer = read_campaign_in_base(args, args.campaign, cell)
    campaign, drift = measured_drift(args, campaign, cell)
    model = ElastostaticModel.from_cell(
        cell,
        geometry,
        model=args.model,
        sampler=elastostatic_sampler(args.sampler, n_draws=args.draws),
        noise=args.noise,
        # Draws the user chose are kept as chosen; the default ones grow until they converge.
        extensions=EXTENSIONS if args.draws is None else 0,
    )
    try:
        results = model.fit(campaign, np.random.default_rng(args.seed))
        test_pose = predict_cell_test_pose(results, cell)
    except EquilibriumError as exc:
        raise InputError(f"the exact model found no static equilibrium ({exc}); try --model linear", source=args.campaign) from None
    if drift is not None:
        # the posterior file says what was taken out of the campaign it was fitted to
        results.tree.attrs["nest_drift"] = json.dumps(drift)
    if args.posterior:
        write_atomically("--posterior", args.posterior, results.save)

    payload = {"campaign": args.campaign} | results.to_json() | {"test_pose": test_pose.to_json()}
    payload["diagnostics"]["seed"] = args.seed
    payload |= {"geometry": identified} if identified else {}
    if transfer is not None:
        payload["registration"] = {"source": args.registration} | transfer.to_json()
    if drift is not None:
        payload["drift"] = drift
    text = "\n".join([*_geometry_lines(identified), _text(results, test_pose, args, cell.reference),
                      *registration_lines(transfer, args.registration), *nests_lines(drift)])
    return CommandOutput(payload=json_safe(payload), text=text)


def _geometry_prior(args: argparse.Namespace, cell):
    """The compensator geometry's posterior from ``--geometry``, as the prior of this fit."""
    from pathlib import Path

    from bayescal.errors import InputError
    from bayescal.inference.priors import posterior_geometry

    if not Path(args.geometry).is_file():
        what = "is a folder" if Path(args.geometry).is_dir() else "file not found"
        raise InputError(f"{what}; expected the NetCDF file `bayescal geometry --posterior` writes", source=args.geometry)
    if cell.compensator is None:
        raise InputError("--geometry: the config has no [compensator], so there is no compensator geometry to propagate", source=args.config)
    return posterior_geometry(args.geometry, cell.compensator)


def _on_identified_geometry(cell, path: str):
    """``cell`` with its robot's joint placements corrected as the kinematic calibration at ``path`` identified, and the
    JSON block that says so.

    Only the joint placements move the deflections: the calibration's base placement (tracker to robot) does not
    enter a campaign already in the robot's base frame, and the markers stay the cell's (the calibration's reflector
    positions are those of its own points cell).
    """
    import dataclasses

    from bayescal.kinematics.axes import corrected_robot
    from bayescal.kinematics.results import read_joint_corrections

    corrections, corrected = read_joint_corrections(path, cell.robot.joint_names)
    identified = dataclasses.replace(cell, robot=corrected_robot(cell.robot, corrections))
    return identified, {"kinematics": path, "joints_corrected": list(corrected),
                        "not_applied": ["the base placement in the tracker frame", "the reflector positions"]}


def _geometry_lines(identified: dict | None) -> list[str]:
    if identified is None:
        return []
    return [f"geometry: the one identified in {identified['kinematics']} (joint placements of "
            f"{', '.join(identified['joints_corrected'])}; not applied: {' and '.join(identified['not_applied'])})"]


def _text(results, test_pose, args, reference_file) -> str:
    import pandas as pd

    from bayescal.inference.identifiability import grouped
    from bayescal.reference import beside_published, read_paper_reference, width_3sd_pct
    from bayescal.reports.numbers import rounded_pair, with_uncertainty

    parameters = results.parameters()
    estimates = pd.DataFrame(
        {name: (entry.get("mean", math.nan), entry.get("sd", math.nan)) for name, entry in parameters.items()}, index=["mean", "sd"]
    ).T
    # Only a cell that names published results of its own robot is compared with them.
    compared = reference_file is not None
    if compared:
        paper = beside_published(estimates, "IV", read_paper_reference(reference_file))
    else:
        paper = estimates.assign(half_width_3sd=3 * estimates["sd"], width_3sd_pct=width_3sd_pct(estimates["mean"], estimates["sd"]))
    units = results.parameter_units
    reasons = {k: v for k, v in results.identifiability.not_identifiable.items() if k in units}
    lines = [
        f"{args.campaign}: {results.n_equations} equations ({results.n_rows} rows x 3 coordinates), "
        f"{results.model} model, {results.sampler_name}, seed {args.seed}",
        "",
        f"{'parameter':<10}{'unit':<12}{'mean':>10}{'±3σ':>10}{'width':>8}"
        + (f"   | {'Table IV':>9}{'±3σ':>8}{'width':>8}" if compared else ""),
    ]
    for name, row in paper.iterrows():
        published = "" if not compared else "   | " + (
            f"{row['published']:>9.4g}{row['published_half_width_3sd']:>8.3g}{row['published_width_pct']:>7.1f}%"
            if math.isfinite(row["published"])
            else f"{'–':>9}"
        )
        unit = units[name]
        if "mean" in parameters[name]:
            mean, half = rounded_pair(row["mean"], row["half_width_3sd"])
            lines.append(f"{name:<10}{unit:<12}{mean:>10}{half:>10}{row['width_3sd_pct']:>7.1f}%{published}")
        else:
            lines.append(f"{name:<10}{unit:<12}{'not identifiable':>28}{published}")
    lines.append("Intervals are mean ± 3 sd, rounded to two digits of the 3 sd; widths 3 sd / |mean|" + (" (Table IV: Klimchik et al.)." if compared else "."))
    if reasons:
        lines += ["", "Not identifiable:"]
        for names, reason in grouped(reasons):
            lines += textwrap.wrap(f"{', '.join(names)}: {reason}.", width=100, initial_indent="  ", subsequent_indent="    ")
        weak = results.weakly_determined()
        if weak:
            listed = ", ".join(weak)
            lines.append(f"  The posterior of {listed} is kept in the DataTree and in the JSON's weakly_determined block.")
    j = -1 if results.joint is None else results.joint + 1
    per_angle = [
        f"  q{j} = {angle:>8.2f} deg  {with_uncertainty(entry['mean'], entry['hi3'] - entry['mean'], 'urad/(N m)')}"
        for angle, entry in results.per_angle().items()
        if "mean" in entry
    ]
    if per_angle:
        lines += ["", f"Joint {j} with its compensator at each campaign angle (±3σ; the paper's Fig. 7):", *per_angle]
    lines += _closing_lines(results, test_pose, reasons)
    return "\n".join(lines)



def _closing_lines(results, test_pose, reasons) -> list[str]:
    """Diagnostics, the test pose (errors in μm, deflections in mm) and what to do next."""
    from bayescal.inference.equations import HANGING_ONLY_REASON
    from bayescal.reports.next_steps import calibration_next_steps
    from bayescal.reports.numbers import error_um
    from bayescal.reports.test_pose import test_pose_lines
    from bayescal.sampling.summary import ESS_LIMIT, R_HAT_LIMIT, converged

    d = results.diagnostics()
    lines = [
        "",
        f"R-hat max {d['r_hat_max']:.3f}, bulk ESS min {d['ess_bulk_min']:.0f}, tail ESS min {d['ess_tail_min']:.0f}, "
        f"residual rms {error_um(d['residual_rms_mm'])}" + (f", χ²/dof {d['chi2_per_dof']:.2f}" if d["chi2_per_dof"] is not None else ""),
        f"identifiability: rank {results.identifiability.rank} of {len(results.identifiability.names)}, "
        f"condition number {results.identifiability.condition_number:.3g} (unit columns)",
        f"(wanted: R-hat ≤ {R_HAT_LIMIT}, both ESS ≥ {ESS_LIMIT}; χ²/dof near 1: residuals as large as the tracker's noise; "
        "rank below the columns: some compliances not identifiable; docs/glossary.md)",
    ]
    block = test_pose.to_json()
    q9973 = None
    if block.get("available", True):
        q9973 = block["residual_error_mm"]["q99.73"]
        lines += test_pose_lines(block)
    else:
        lines.append(f"test pose: not predicted: {block['reason']}")
    limited = [name for name, reason in reasons.items() if reason.endswith(HANGING_ONLY_REASON)]
    advice = calibration_next_steps(d, sorted(reasons), q9973, converged(d), limited)
    return lines + ["", *textwrap.wrap(advice, width=100)]
