"""The ``bayescal`` command line: a thin layer over the library.

Each subcommand lives in its own module of this package and provides
``add_parser(subparsers)``, which registers the subcommand with a ``run``
default.  ``run(args)`` returns a :class:`~bayescal.cli._command.CommandOutput`;
this module prints it as JSON (``--json``) or as text, and turns an
:class:`~bayescal.errors.InputError` into a one-line message and exit status 2.
A bad option value is reported by the parser the same way: one line, status 2.
Output files go through :mod:`bayescal.cli._command`'s guard and atomic writer.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import warnings
from collections.abc import Sequence

from bayescal.errors import InputError

__all__ = ["main"]

COMMANDS = ("geometry", "simulate", "calibrate", "plan", "study", "critique", "report", "compensate")


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like the errors on files."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayescal",
        description="Probabilistic identification of geometric and elastostatic parameters of heavy industrial robots.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line and return the exit status (0 success, 2 bad input)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit:
        # A bad option value (status 2) or --help (status 0): the message is printed already.
        return exit.code if isinstance(exit.code, int) else 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            output = args.run(args)
        except InputError as error:
            print(f"bayescal {args.command}: error: {error}", file=sys.stderr)
            return 2
        except OSError as error:
            # An output path that cannot be written is the user's to fix, not a bug.
            print(f"bayescal {args.command}: error: {error.filename}: {error.strerror}", file=sys.stderr)
            return 2
    # Warnings go out before the result, so that a reader of a terminal sees them
    # above the table and a JSON consumer still gets clean stdout.
    messages = [str(warning.message) for warning in caught if issubclass(warning.category, UserWarning)]
    for message in dict.fromkeys(messages):
        print(f"bayescal {args.command}: warning: {message}", file=sys.stderr)
    sys.stderr.flush()
    if args.json:
        json.dump(output.payload, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(output.text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
