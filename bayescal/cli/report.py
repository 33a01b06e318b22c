"""``bayescal report``: the calibration review, one HTML page with its Markdown summary and its numbers."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from ._command import CommandOutput, add_common_options, check_output, write_atomically

__all__ = ["add_parser", "run"]


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
    parser.add_argument("-o", "--output", required=True, metavar="FOLDER", help="report folder, created when missing (its parent must exist)")
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.errors import InputError

    inputs = {
        "the --geometry posterior": args.geometry,
        "the --calibration posterior": args.calibration,
        "the campaign": args.campaign,
        "the config": args.config,
        "the --plan file": args.plan,
        "the --critique file": args.critique,
        "the --study file": args.study,
        "the --compensation file": args.compensation,
    }
    if not any(value for key, value in inputs.items() if key not in ("the campaign", "the config")):
        raise InputError("nothing to report: give --geometry, --calibration, --plan, --critique, --study or --compensation", source="bayescal report")
    if args.calibration and not (args.campaign and args.config):
        raise InputError("--calibration needs the --campaign and the --config it was computed from", source="--calibration")
    for option, path in (("--geometry", args.geometry), ("--calibration", args.calibration), ("--campaign", args.campaign),
                         ("--config", args.config), ("--plan", args.plan), ("--critique", args.critique), ("--study", args.study),
                         ("--compensation", args.compensation)):
        if path and not Path(path).is_file():
            raise InputError(f"{path}: {'is a folder' if Path(path).is_dir() else 'file not found'}", source=option)
    folder = _check_folder(args.output, inputs)

    review_inputs = _read_inputs(args)

    from bayescal.reports.review import HTML_FILE, render_review

    files = render_review(review_inputs)
    folder.mkdir(exist_ok=True)
    for name in files:
        check_output("--output", folder / name, inputs)
    for name, content in files.items():
        write_atomically("--output", folder / name, lambda path, content=content: path.write_bytes(content))
    index = folder / HTML_FILE
    figures = sorted(name for name in files if name.endswith(".png"))
    payload = {"report": str(index), "files": sorted(files), "figures": len(figures)}
    text = f"wrote {index} with {len(figures)} figures, and {folder / 'summary.md'}, {folder / 'numbers.json'}"
    return CommandOutput(payload=payload, text=text)


def _check_folder(output: str, inputs: dict) -> Path:
    """The report folder, refused when it is an input file, a file, or its parent cannot take it."""
    from bayescal.errors import InputError

    if not output.strip():
        raise InputError("expected the name of a folder to write, got an empty text", source="--output")
    folder = Path(output)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{output} is a file; expected a folder for the report", source="--output")
    if folder.is_dir():
        check_output("--output", folder / "index.html", inputs)
        return folder
    parent = Path(os.path.realpath(folder)).parent
    if not parent.is_dir():
        raise InputError(f"the folder {parent} that should hold the report does not exist; create it first", source="--output")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"cannot create the report folder in {parent} (permission denied)", source="--output")
    return folder


def _read_inputs(args: argparse.Namespace):
    from bayescal.reports.review import ReviewInputs
    from bayescal.sampling.summary import load

    sources = {}
    review = ReviewInputs(sources=sources, seed=args.seed)
    if args.geometry:
        sources["geometry posterior"] = args.geometry
        review.geometry = _load_tree(args.geometry, "--geometry", load, needs=("L", "a_x", "a_y"), foreign="k2_q2")
    if args.calibration:
        from bayescal.cell.campaign import read_campaign
        from bayescal.cell.config import load_cell
        from bayescal.inference.elastostatic import restore_results
        from bayescal.inference.priors import posterior_geometry
        from bayescal.inference.testpose import predict_cell_test_pose
        from bayescal.studies.residuals import residual_table

        sources |= {"calibration posterior": args.calibration, "campaign": args.campaign, "cell": args.config}
        cell = load_cell(args.config)
        campaign = read_campaign(args.campaign, cell=cell)
        tree = _load_tree(args.calibration, "--calibration", load, needs=("k2_q2", "sigma"), foreign="R")
        geometry = posterior_geometry(args.geometry) if args.geometry else None
        results = restore_results(cell, campaign, tree, geometry)
        review.results, review.campaign, review.cell = results, campaign, cell
        review.residuals = residual_table(results, campaign, cell)
        review.test_pose = predict_cell_test_pose(results, cell)
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


def _load_tree(path: str, option: str, load, needs: tuple[str, ...], foreign: str):
    """The posterior at ``path``, refused when it lacks a variable of ``needs`` or has ``foreign``, a variable only
    the other kind of posterior has (an elastostatic posterior also holds the geometry it sampled)."""
    from bayescal.errors import InputError

    try:
        tree = load(path)
        posterior = tree["posterior"]
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"cannot read a posterior DataTree ({type(exc).__name__})", source=path) from None
    missing = [name for name in needs if name not in posterior]
    if missing:
        raise InputError(f"the posterior has no variable {', '.join(repr(m) for m in missing)}: is it the file {option} expects?", source=path)
    if foreign in posterior:
        other = "--calibration" if option == "--geometry" else "--geometry"
        raise InputError(f"the posterior has the variable '{foreign}' of a {other} posterior: is it the file {option} expects?", source=path)
    return tree


def _read_json(path: str, option: str) -> dict:
    from bayescal.errors import InputError

    try:
        with open(path, encoding="utf-8") as stream:
            data = json.load(stream)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg} at character {exc.colno})", source=path, line=exc.lineno) from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file", source=path) from None
    if not isinstance(data, dict):
        raise InputError(f"expected a JSON object (the output of {option[2:]} --json), got a {type(data).__name__}", source=path)
    return data


def _read_csv(path: str, option: str):
    import pandas as pd

    from bayescal.errors import InputError

    try:
        frame = pd.read_csv(path, comment="#")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"not a readable CSV table ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})", source=path) from None
    if frame.empty:
        raise InputError("the table has no rows", source=path)
    return frame
