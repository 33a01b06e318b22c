"""``python -m bayescal_studies reports FOLDER``: regenerate the reports committed in ``reports/``.

Each report's findings are computed by :func:`bayescal_studies.studies.paper_reports.paper_findings`
and rendered by :func:`bayescal_studies.reports.paper.render_paper_report` (the detection report by
:func:`bayescal_studies.reports.detection.render_report`).  Every file goes through the output guard,
before any work, and is put in place with the others by :func:`bayescal.output.write_folder`.  The
command runs through :func:`bayescal.cli.main`: one-line errors with status 2, signals as ``bayescal``'s.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from bayescal.cli import CommandParser, main as run_command
from bayescal.cli._command import CommandOutput
from bayescal.output import guard_outputs, write_folder

__all__ = ["build_parser", "main", "run_paper_reports"]

PROGRAM = "python -m bayescal_studies"
"""How the research commands are run and named in their messages (no console script: nothing to install)."""

DEFAULT_DATA = "data"
"""The folder of the paper's data files, relative to where the command runs (the repository's root for ``make reports``)."""


def build_parser() -> argparse.ArgumentParser:
    """The research command line: ``reports``, the committed reports on the paper's data."""
    from bayescal_studies.studies.paper_reports import PAPER_REPORTS

    parser = CommandParser(prog=PROGRAM, description="The Monte-Carlo studies and paper reports of bayescal.")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    reports = subparsers.add_parser(
        "reports",
        help="regenerate the committed reports on the paper's data",
        description="Regenerate the reports on the paper's data (geometry.md, twin.md, elastostatic.md, detection.md "
        "and their figures) into FOLDER, each with its documented seed.",
    )
    reports.add_argument("paper_reports", metavar="FOLDER", help="the folder of the reports (make reports: reports)")
    reports.add_argument("--paper-data", metavar="FOLDER", default=DEFAULT_DATA,
                         help=f"folder of the paper's data files (default {DEFAULT_DATA})")
    reports.add_argument("--only", action="append", choices=PAPER_REPORTS, metavar="REPORT",
                         help=f"regenerate only this report ({', '.join(PAPER_REPORTS)}); repeatable")
    reports.add_argument("--json", action="store_true", help="print the reports and files written as JSON on stdout")
    reports.set_defaults(run=run_paper_reports)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the research command line and return its exit status (as :func:`bayescal.cli.main`)."""
    return run_command(argv, program=PROGRAM, build=build_parser)


def run_paper_reports(args: argparse.Namespace) -> CommandOutput:
    """Compute, render and write the committed reports named by ``args.only`` (all by default)."""
    from bayescal.errors import InputError
    from bayescal_studies.reports.paper import PAPER_REPORT_FILES, render_paper_report
    from bayescal_studies.studies.paper_reports import PAPER_REPORTS, PAPER_SEEDS, PaperSources, paper_findings

    sources = PaperSources.in_folder(args.paper_data)
    for what, path in sources.inputs().items():
        if not path.is_file():
            raise InputError(f"{path}: {what} not found in the --paper-data folder", source="--paper-data")
    names = [name for name in PAPER_REPORTS if name in (args.only or PAPER_REPORTS)]
    files_of = tuple(file for name in names for file in PAPER_REPORT_FILES[name])
    guard_outputs(sources.inputs(), folders={"FOLDER": (args.paper_reports, files_of)})
    files: dict[str, bytes] = {}
    for name in names:
        if not args.json:
            print(f"computing {name} (seed {PAPER_SEEDS[name]})", file=sys.stderr, flush=True)
        if name == "detection":
            from bayescal_studies.reports.detection import render_report

            files["detection.md"] = render_report(paper_findings(name, sources)).encode("utf-8")
        else:
            files |= render_paper_report(paper_findings(name, sources))

    def write(staging: Path) -> None:
        for file, content in files.items():
            (staging / file).write_bytes(content)

    written = write_folder("FOLDER", args.paper_reports, write)
    payload = {"reports": names, "files": [str(path) for path in written]}
    return CommandOutput(payload=payload, text="\n".join(str(path) for path in written))

