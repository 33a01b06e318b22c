"""``bayescal calibrate``: joint compliances and compensator spring from a campaign CSV."""

from __future__ import annotations

import argparse
import json

from bayescal.jsonsafe import json_safe

from ._command import CommandOutput, add_common_options, check_output, whole_number, write_atomically
from ._nests import add_nests_option, fitted_drift, nests_lines
from ._registered import add_registration_option, read_campaign_in_base, registration_lines

__all__ = ["add_parser", "run"]

MIN_DRAWS = 100
"""Fewest kept draws per chain the command accepts."""
DRIFT_DRAWS = 8
"""Draws of the measured drift the calibration is integrated over by default (``--drift-draws``): on the twin at
0.6 mm/h (60 campaigns) the fewest of 2, 4 and 8 whose compliances lie within 1, 2 and 3 sd at the nominal rates to
2 binomial sd; 4 fell short at 1 and 3 sd, at about 60 % of the time (docs/critique.md, *Drift*)."""
MIN_DRIFT_DRAWS = 2
"""Fewest drift draws accepted: one draw is one guess of the drift, its error then in no interval."""


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
    parser.add_argument(
        "--drift-draws", metavar="D", type=whole_number(MIN_DRIFT_DRAWS, "one draw is one guess of the drift, its error in no interval"),
        default=None,
        help=f"with --nests or --drift-from-repeats: draws of the drift's posterior the calibration is integrated over, one "
        f"calibration per draw taken out of the readings, their posteriors pooled (default {DRIFT_DRAWS}, at least "
        f"{MIN_DRIFT_DRAWS}; the time grows about in proportion)",
    )
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
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
    track = fitted_drift(args, campaign, cell)
    if track is None and args.drift_draws is not None:
        raise InputError("expected with --nests or --drift-from-repeats: without them no drift is measured", source="--drift-draws")
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
        results, drift = _fit(args, model, campaign, track)
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
    document = results.document(test_pose, args.campaign, args.seed, cell.reference)
    text = "\n".join([*_geometry_lines(identified), document.as_text(),
                      *registration_lines(transfer, args.registration), *nests_lines(drift)])
    return CommandOutput(payload=json_safe(payload), text=text)


def _fit(args: argparse.Namespace, model, campaign, track):
    """The calibration of ``campaign``, integrated over ``--drift-draws`` draws of the drift ``track`` when there is one,
    and the JSON block of the drift removed (None without)."""
    import numpy as np

    rng = np.random.default_rng(args.seed)
    if track is None:
        return model.fit(campaign, rng), None
    from bayescal.inference.mixture import fit_integrated

    count = args.drift_draws or DRIFT_DRAWS
    drift = track.to_json(campaign) | ({"file": args.nests} if args.nests else {}) | {"draws_integrated": count}
    return fit_integrated(model, track.remove(campaign), track.removed_draws(campaign, rng, count), rng), drift


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
    from bayescal.kinematics.saved import read_joint_corrections

    corrections, corrected = read_joint_corrections(path, cell.robot.joint_names)
    identified = dataclasses.replace(cell, robot=corrected_robot(cell.robot, corrections))
    return identified, {"kinematics": path, "joints_corrected": list(corrected),
                        "not_applied": ["the base placement in the tracker frame", "the reflector positions"]}


def _geometry_lines(identified: dict | None) -> list[str]:
    if identified is None:
        return []
    return [f"geometry: the one identified in {identified['kinematics']} (joint placements of "
            f"{', '.join(identified['joints_corrected'])}; not applied: {' and '.join(identified['not_applied'])})"]
