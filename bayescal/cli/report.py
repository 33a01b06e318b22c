"""``bayescal report``: the calibration review, one HTML page with its Markdown summary and its numbers."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bayescal.output import guard_outputs, record_read, write_folder

from ._command import CommandOutput, add_common_options
from ._nests import add_nests_option, measured_drift
from ._registered import read_campaign_in_base
from .paper_reports import add_options as add_paper_options, run_paper_reports

__all__ = ["add_parser", "run", "MAX_CHI2_PER_DOF"]

MAX_CHI2_PER_DOF = 100.0
"""Largest χ²/dof of a calibration against the campaign and cell given beside it: residuals 10 times the
tracker noise the cell states.  A short calibration of the twin's Table III campaign gives 0.87 on that
campaign and 3588 beside a campaign of the same plan on a robot twice as compliant (tests/cli/test_hostile.py)."""

_SCHEMAS = {
    "--plan": ({"criterion": (float, int, type(None)), "parameters": dict, "configurations": int}, "verdict", "bayescal plan --json"),
    "--critique": ({"verdict": str, "causes": list, "evidence": dict, "gain": dict}, "parameters", "bayescal critique --json"),
    "--registration": ({"axes": dict, "frames": dict}, "parameters", "bayescal axes -o"),
}
"""Per JSON option: the keys it must have with their types, a key only the other kind has, and the command that writes it."""

LADDER_KEYS = {"verdict": str, "rungs": list, "steps": list, "without": list, "folds": int}
"""The keys a model ladder's JSON must have, with their types."""

VERDICTS = ("adequate", "misfit")
"""The verdicts `bayescal critique` gives."""

STUDY_COLUMNS = ("angles", "per_angle", "noise_fraction", "test_pose_rms_mm")
"""Columns every q2-angle study table has (`bayescal study q2-angles -o`)."""


def add_parser(subparsers) -> None:
    parser = subparsers.add_parser(
        "report",
        help="write the calibration review: an HTML page with figures, a Markdown summary and a JSON of every number",
        description=(
            "Write the review of a calibration into a folder: index.html (figures as PNG files beside it), "
            "summary.md and numbers.json. Sections appear for what is given: the geometry posterior beside "
            "Table II; the elastostatic posterior (with its campaign and cell) beside Table IV, what is not "
            "identifiable, convergence, pair and residual plots, eta(q2), joint 2's compliance and the error at "
            "the test pose; and the plan, q2-angle study and critique files when given."
        ),
    )
    parser.add_argument("--geometry", metavar="GEOMETRY.nc", help="geometry posterior from `bayescal geometry --posterior`")
    parser.add_argument("--calibration", metavar="CALIBRATION.nc", help="elastostatic posterior from `bayescal calibrate --posterior`")
    parser.add_argument("--campaign", metavar="CAMPAIGN.csv", help="the campaign the calibration was computed from (with --calibration)")
    parser.add_argument("--config", metavar="CELL.toml", help="the cell file of the calibration (with --calibration)")
    parser.add_argument("--plan", metavar="PLAN.json", help="JSON printed by `bayescal plan --json`")
    parser.add_argument("--critique", metavar="CRITIQUE.json", help="JSON printed by `bayescal critique --json`")
    parser.add_argument("--study", metavar="STUDY.csv", help="a q2-angle study table (CSV)")
    parser.add_argument("--compensation", metavar="COMPENSATED.csv", help="a compensated program from `bayescal compensate -o`")
    parser.add_argument(
        "--registration",
        metavar="REG.json",
        help="registration from `bayescal axes -o`: shown on the page, and the --campaign is read in the tracker frame and moved into its base frame",
    )
    parser.add_argument("-o", "--output", metavar="FOLDER", help="report folder, created when missing (its parent must exist)")
    add_nests_option(parser)
    add_paper_options(parser)
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.errors import InputError

    if args.paper_reports:
        return run_paper_reports(args)
    if args.only:
        raise InputError("--only selects among the --paper-reports; give --paper-reports FOLDER", source="--only")
    if not args.output:
        raise InputError("expected -o FOLDER, the folder of the review (or --paper-reports FOLDER)", source="-o")
    inputs = {
        "the --geometry posterior": args.geometry,
        "the --calibration posterior": args.calibration,
        "the campaign": args.campaign,
        "the config": args.config,
        "the --plan file": args.plan,
        "the --critique file": args.critique,
        "the --study file": args.study,
        "the --compensation file": args.compensation,
        "the --registration file": args.registration,
        "the --nests file": args.nests,
    }
    if not any(value for key, value in inputs.items() if key not in ("the campaign", "the config", "the --nests file")):
        raise InputError("nothing to report: give --geometry, --calibration, --plan, --critique, --study, --compensation or "
                         "--registration", source="bayescal report")
    if args.calibration and not (args.campaign and args.config):
        raise InputError("--calibration needs the --campaign and the --config it was computed from", source="--calibration")
    if (args.nests or args.drift_from_repeats) and not args.calibration:
        raise InputError("expected with --calibration and its --campaign: the drift measured is removed from the campaign",
                         source="--nests" if args.nests else "--drift-from-repeats")
    for option, path in (("--geometry", args.geometry), ("--calibration", args.calibration), ("--campaign", args.campaign),
                         ("--config", args.config), ("--plan", args.plan), ("--critique", args.critique), ("--study", args.study),
                         ("--compensation", args.compensation), ("--registration", args.registration), ("--nests", args.nests)):
        if path and not Path(path).is_file():
            raise InputError(f"{path}: {'is a folder' if Path(path).is_dir() else 'file not found'}", source=option)
    from bayescal.reports.review import HTML_FILE, render_review

    # The page's own files are checked now; the figures' names are known once rendered and checked then.
    guard_outputs(inputs, folders={"--output": (args.output, (HTML_FILE, "summary.md", "numbers.json"))})
    review_inputs = _read_inputs(args)
    files = render_review(review_inputs)
    guard_outputs(inputs, folders={"--output": (args.output, tuple(files))})

    def write(staging: Path) -> None:
        for name, content in files.items():
            (staging / name).write_bytes(content)

    write_folder("--output", args.output, write)
    folder = Path(args.output)
    index = folder / HTML_FILE
    figures = sorted(name for name in files if name.endswith(".png"))
    payload = {"report": str(index), "files": sorted(files), "figures": len(figures)}
    text = f"wrote {index} with {len(figures)} figures, and {folder / 'summary.md'}, {folder / 'numbers.json'}"
    return CommandOutput(payload=payload, text=text)


def _read_inputs(args: argparse.Namespace):
    from bayescal.reports.review import ReviewInputs

    from bayescal.cell.config import load_cell
    from bayescal.inference.priors import posterior_geometry

    sources = {}
    review = ReviewInputs(sources=sources, seed=args.seed)
    cell = load_cell(args.config) if args.config else None
    geometry = None
    if args.geometry:
        sources["geometry posterior"] = args.geometry
        review.geometry = _load_tree(args.geometry, "--geometry", needs=("L", "a_x", "a_y"), foreign="k2_q2")
        # The check calibrate applies: units, finite draws and, with a cell, nearness to its compensator.
        geometry = posterior_geometry(args.geometry, None if cell is None else cell.compensator)
    if args.registration:
        from bayescal.registration import read_frame

        sources["registration"] = args.registration
        review.registration = _read_json(args.registration, "--registration")
        for name in review.registration["frames"]:
            read_frame(args.registration, name, cell)
    if args.calibration:
        from bayescal.compensation.calibration import check_calibration_robot
        from bayescal.studies.review import calibration_findings

        sources |= {"calibration posterior": args.calibration, "campaign": args.campaign, "cell": args.config}
        campaign, cell, _ = read_campaign_in_base(args, args.campaign, cell)
        # the campaign as `calibrate --nests` (or --drift-from-repeats) fitted it: the drift measured taken out
        campaign, drift = measured_drift(args, campaign, cell)
        if drift is not None and args.nests:
            sources["nests"] = args.nests
        from bayescal.inference.parameters import ParameterRegistry

        # A robot without a compensator has no per-angle compliances; the geometry's own 'R' tells the other kind apart.
        per_angle = ParameterRegistry.of_cell(cell).per_angle_variable if cell is not None else None
        tree = _load_tree(args.calibration, "--calibration", needs=(*([per_angle] if per_angle else []), "sigma"), foreign="R")
        check_calibration_robot(tree, cell, args.calibration)
        calibration = calibration_findings(cell, campaign, tree, geometry)
        _check_fit(calibration.results, args)
        review.results, review.campaign, review.cell = calibration.results, campaign, cell
        review.residuals, review.test_pose = calibration.residuals, calibration.test_pose
    if args.plan:
        sources["plan"] = args.plan
        review.plan = _read_json(args.plan, "--plan")
    if args.critique:
        sources["critique"] = args.critique
        review.critique = _read_json(args.critique, "--critique")
    if args.study:
        sources["q2-angle study"] = args.study
        review.study = _read_csv(args.study, "--study")
    if args.compensation:
        from bayescal.reports.compensation import read_compensated

        sources["compensated program"] = args.compensation
        review.compensation = read_compensated(args.compensation)
    return review


def _load_tree(path: str, option: str, needs: tuple[str, ...], foreign: str):
    """The posterior at ``path``, refused when it lacks a variable of ``needs``, has ``foreign``, a variable only
    the other kind of posterior has (an elastostatic posterior also holds the geometry it sampled), or non-finite draws."""
    import numpy as np

    from bayescal.errors import InputError
    from bayescal.sampling.summary import read_posterior

    tree, posterior = read_posterior(path)
    missing = [name for name in needs if name not in posterior]
    if missing:
        raise InputError(f"the posterior has no variable {', '.join(repr(m) for m in missing)}: is it the file {option} expects?", source=path)
    if foreign in posterior:
        other = "--calibration" if option == "--geometry" else "--geometry"
        raise InputError(f"the posterior has the variable '{foreign}' of a {other} posterior: is it the file {option} expects?", source=path)
    for name, values in posterior.data_vars.items():
        bad = int(np.count_nonzero(~np.isfinite(np.asarray(values.values, dtype=float))))
        if bad:
            raise InputError(f"the variable has {bad} non-finite draws; expected finite draws", source=path, column=str(name))
    return tree


def _read_json(path: str, option: str) -> dict:
    from bayescal.errors import InputError

    record_read(path, f"the {option} file")
    try:
        with open(path, encoding="utf-8") as stream:
            data = json.load(stream)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg} at character {exc.colno})", source=path, line=exc.lineno) from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file", source=path) from None
    required, foreign, writer = _SCHEMAS[option]
    if not isinstance(data, dict):
        raise InputError(f"expected a JSON object (the output of {writer}), got a {type(data).__name__}", source=path)
    if foreign in data:
        raise InputError(f"the JSON has the key '{foreign}' of another command's output; {option} expects the output of {writer}", source=path)
    from bayescal.kinematics.ladder import LADDER_KIND

    if option == "--critique" and data.get("kind") == LADDER_KIND:
        _check_keys(data, LADDER_KEYS, path, "bayescal critique POSITIONS.csv --config POINTS_CELL.toml --json")
        return data
    _check_keys(data, required, path, writer)
    if option == "--critique" and data["verdict"] not in VERDICTS:
        raise InputError(f"expected a verdict {' or '.join(VERDICTS)}, got {data['verdict']!r}", source=path, column="verdict")
    return data


def _check_keys(data: dict, required: dict, path: str, writer: str) -> None:
    from bayescal.errors import InputError

    for key, kind in required.items():
        if key not in data or not isinstance(data[key], kind) or isinstance(data[key], bool):
            found = "no such key" if key not in data else f"a {type(data[key]).__name__}"
            raise InputError(f"expected the key '{key}' of the output of {writer}, found {found}", source=path, column=key)


def _read_csv(path: str, option: str):
    import pandas as pd

    from bayescal.errors import InputError

    record_read(path, f"the {option} table")
    try:
        frame = pd.read_csv(path, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"not a readable CSV table ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})", source=path) from None
    if frame.empty:
        raise InputError("the table has no rows", source=path)
    missing = [column for column in STUDY_COLUMNS if column not in frame.columns]
    if missing:
        raise InputError(f"no column {', '.join(missing)}: expected the table of bayescal study q2-angles -o", source=path)
    for column in STUDY_COLUMNS:
        if not pd.api.types.is_numeric_dtype(frame[column]):
            raise InputError("expected numbers", source=path, column=column)
    return frame


def _check_fit(results, args: argparse.Namespace) -> None:
    """Refuse a calibration whose χ²/dof against the given campaign and cell shows it was computed from other data."""
    from bayescal.errors import InputError

    chi2 = results.diagnostics().get("chi2_per_dof")
    if chi2 is not None and chi2 > MAX_CHI2_PER_DOF:
        raise InputError(
            f"the calibration fits the campaign {args.campaign} with χ²/dof = {chi2:.2f}, above {MAX_CHI2_PER_DOF:g} (residuals "
            f"{chi2 ** 0.5:.0f} times the tracker noise of {args.config}): was it computed from this campaign and cell?",
            source=args.calibration,
        )
