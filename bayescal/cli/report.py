"""``bayescal report``: the calibration review, one HTML page with its Markdown summary and its numbers."""

from __future__ import annotations

import argparse
import gc
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bayescal.output import guard_outputs, record_read, write_folder

from ._command import CommandOutput, add_common_options
from ._nests import add_nests_option, measured_drift
from ._registered import read_campaign_in_base

__all__ = ["add_parser", "run"]

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
    add_common_options(parser)
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> CommandOutput:
    from bayescal.errors import InputError

    if not args.output:
        raise InputError("expected -o FOLDER, the folder of the review", source="-o")
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
    with _without_cyclic_collection():
        from bayescal.reports.review import HTML_FILE, render_review

        # The page's own files are checked now; the figures' names are known once rendered and checked then.
        guard_outputs(inputs, folders={"--output": (args.output, (HTML_FILE, "summary.md", "numbers.json"))})
        files = render_review(_read_inputs(args))
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


@contextmanager
def _without_cyclic_collection() -> Iterator[None]:
    """Python's cyclic garbage collector paused, then restored as it was.

    Reading the inputs imports most of the package's dependencies and rendering the figures builds Matplotlib's
    artists by the tens of thousands; nearly all of them live until the page is written, so the collector's passes
    (four full ones on ``make demo``'s review) scan them for nothing: 0.3 s of the command's 4 s of CPU.  A review's
    garbage is a few figures, freed when the collector runs again.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _read_inputs(args: argparse.Namespace):
    from bayescal.reports.review import ReviewInputs

    from bayescal.cell.config import load_cell
    from bayescal.inference.priors import posterior_geometry
    from bayescal.sampling.summary import read_posterior_of

    sources = {}
    review = ReviewInputs(sources=sources, seed=args.seed)
    cell = load_cell(args.config) if args.config else None
    geometry = None
    if args.geometry:
        sources["geometry posterior"] = args.geometry
        review.geometry = read_posterior_of(args.geometry, "--geometry", needs=("L", "a_x", "a_y"), foreign="k2_q2", other="--calibration")
        # The check calibrate applies: units, finite draws and, with a cell, nearness to its compensator.
        geometry = posterior_geometry(args.geometry, None if cell is None else cell.compensator)
    if args.registration:
        from bayescal.registration import read_frame
        from bayescal.registration.register import RegistrationFindings

        sources["registration"] = args.registration
        review.registration = RegistrationFindings.load(args.registration, "--registration")
        for name in review.registration.frames:
            read_frame(args.registration, name, cell)
    if args.calibration:
        _read_calibration(args, cell, geometry, review)
    if args.plan:
        from bayescal.design.plan_design import PlanFindings

        sources["plan"] = args.plan
        review.plan = PlanFindings.load(args.plan, "--plan")
    if args.critique:
        sources["critique"] = args.critique
        review.critique, review.ladder = _read_critique(args.critique)
    if args.study:
        sources["q2-angle study"] = args.study
        review.study = _read_csv(args.study, "--study")
    if args.compensation:
        from bayescal.reports.compensation import read_compensated

        sources["compensated program"] = args.compensation
        review.compensation = read_compensated(args.compensation)
    return review


def _read_calibration(args: argparse.Namespace, cell, geometry, review) -> None:
    """The --calibration posterior restored on its --campaign (the drift taken out as calibrate took it) into ``review``,
    refused when it is not a calibration of this cell's robot or does not fit this campaign."""
    from bayescal.compensation.calibration import check_calibration_robot
    from bayescal.inference.fit_checks import check_fits_campaign
    from bayescal.inference.parameters import ParameterRegistry
    from bayescal.sampling.summary import read_posterior_of
    from bayescal.compensation.review import calibration_findings

    review.sources |= {"calibration posterior": args.calibration, "campaign": args.campaign, "cell": args.config}
    campaign, cell, _ = read_campaign_in_base(args, args.campaign, cell)
    # the campaign as `calibrate --nests` (or --drift-from-repeats) fitted it: the drift measured taken out
    campaign, drift = measured_drift(args, campaign, cell)
    if drift is not None and args.nests:
        review.sources["nests"] = args.nests
    # A robot without a compensator has no per-angle compliances; the geometry's own 'R' tells the other kind apart.
    per_angle = ParameterRegistry.of_cell(cell).per_angle_variable if cell is not None else None
    tree = read_posterior_of(args.calibration, "--calibration", needs=(*([per_angle] if per_angle else []), "sigma"), foreign="R",
                             other="--geometry")
    check_calibration_robot(tree, cell, args.calibration)
    calibration = calibration_findings(cell, campaign, tree, geometry)
    check_fits_campaign(calibration.results, args.campaign, args.config, args.calibration)
    review.results, review.campaign, review.cell = calibration.results, campaign, cell
    review.residuals, review.test_pose = calibration.residuals, calibration.test_pose


def _read_critique(path: str):
    """The --critique file, checked against the schema of the results class that wrote it: a campaign's critique as its
    :class:`~bayescal.critique.results.CritiqueFindings`, or a points cell's model ladder as its
    :class:`~bayescal.kinematics.ladder.LadderFindings` (the pair, the other None)."""
    from bayescal.critique.results import CRITIQUE_JSON, CritiqueFindings
    from bayescal.jsonfiles import read_json_object
    from bayescal.kinematics.ladder import LADDER_JSON, LADDER_KIND, LadderFindings

    data = read_json_object(path, "the --critique file")
    # Both files share the critique's writer in errors until the ladder's kind tells them apart.
    CRITIQUE_JSON.check_kind(data, path, "--critique")
    if data.get("kind") == LADDER_KIND:
        LADDER_JSON.check_keys(data, path)
        return None, LadderFindings.from_json(data)
    return CritiqueFindings.from_json(data, path), None


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
