"""``bayescal report --paper-reports FOLDER``: regenerate the reports committed in ``reports/``.

Each report's findings are computed by :func:`bayescal.studies.paper_reports.paper_findings`
and rendered by :func:`bayescal.reports.paper.render_paper_report` (the detection report by
:func:`bayescal.reports.detection.render_report`).  Every file goes through the output guard,
before any work, and is put in place with the others by :func:`bayescal.output.write_folder`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bayescal.output import guard_outputs, write_folder

from ._command import CommandOutput

__all__ = ["add_options", "run_paper_reports"]

DEFAULT_DATA = "data"
"""The folder of the paper's data files, relative to where the command runs (the repository's root for ``make reports``)."""


def add_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--paper-reports``, ``--paper-data`` and ``--only`` to ``bayescal report``."""
    from bayescal.studies.paper_reports import PAPER_REPORTS

    group = parser.add_argument_group("the committed reports (make reports)")
    group.add_argument("--paper-reports", metavar="FOLDER",
                       help="regenerate the reports on the paper's data (geometry.md, twin.md, elastostatic.md, detection.md "
                       "and their figures) into FOLDER, each with its documented seed; takes no other input")
    group.add_argument("--paper-data", metavar="FOLDER", default=DEFAULT_DATA,
                       help=f"folder of the paper's data files with --paper-reports (default {DEFAULT_DATA})")
    group.add_argument("--only", action="append", choices=PAPER_REPORTS, metavar="REPORT",
                       help=f"with --paper-reports, regenerate only this report ({', '.join(PAPER_REPORTS)}); repeatable")


def run_paper_reports(args: argparse.Namespace) -> CommandOutput:
    """Compute, render and write the committed reports named by ``args.only`` (all by default)."""
    from bayescal.errors import InputError
    from bayescal.reports.paper import PAPER_REPORT_FILES, render_paper_report
    from bayescal.studies.paper_reports import PAPER_REPORTS, PAPER_SEEDS, PaperSources, paper_findings

    others = ("geometry", "calibration", "campaign", "config", "plan", "critique", "study", "compensation", "output")
    given = [name for name in others if getattr(args, name, None)]
    if given:
        raise InputError(f"--paper-reports takes no --{given[0]}: it reads the files of --paper-data", source="--paper-reports")
    sources = PaperSources.in_folder(args.paper_data)
    for what, path in sources.inputs().items():
        if not path.is_file():
            raise InputError(f"{path}: {what} not found in the --paper-data folder", source="--paper-data")
    names = [name for name in PAPER_REPORTS if name in (args.only or PAPER_REPORTS)]
    files_of = tuple(file for name in names for file in PAPER_REPORT_FILES[name])
    guard_outputs(sources.inputs(), folders={"--paper-reports": (args.paper_reports, files_of)})
    files: dict[str, bytes] = {}
    for name in names:
        if not args.json:
            print(f"computing {name} (seed {PAPER_SEEDS[name]})", file=sys.stderr, flush=True)
        if name == "detection":
            from bayescal.reports.detection import render_report

            files["detection.md"] = render_report(paper_findings(name, sources)).encode("utf-8")
        else:
            files |= render_paper_report(paper_findings(name, sources))

    def write(staging: Path) -> None:
        for file, content in files.items():
            (staging / file).write_bytes(content)

    written = write_folder("--paper-reports", args.paper_reports, write)
    payload = {"reports": names, "files": [str(path) for path in written]}
    return CommandOutput(payload=payload, text="\n".join(str(path) for path in written))

