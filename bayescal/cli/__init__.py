"""The ``bayescal`` command line: a thin layer over the library.

Each subcommand lives in its own module of this package and provides
``add_parser(subparsers)``, which registers the subcommand with a ``run``
default.  ``run(args)`` returns a :class:`~bayescal.cli._command.CommandOutput`;
this module prints it as JSON (``--json``) or as text, and turns an
:class:`~bayescal.errors.InputError` into a one-line message and exit status 2.
A bad option value is reported by the parser the same way: one line, status 2.
Ctrl-C, SIGTERM (a scheduler's, ``timeout``'s) and SIGHUP (a closed terminal) end any
command the same way: one line saying what was written, the temporary files removed,
and status 128 + the signal's number (130, 143, 129).
Output files and folders go through :mod:`bayescal.output`'s guard and atomic writers.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

from bayescal.errors import InputError

from bayescal.output import forget_reads, forget_written, written_paths

__all__ = ["CommandParser", "main"]

COMMANDS = ("geometry", "simulate", "calibrate", "plan", "study", "critique", "report", "compensate", "axes", "kinematics", "predict", "export")


class CommandParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, like the errors on files."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = CommandParser(
        prog="bayescal",
        description="Probabilistic identification of geometric and elastostatic parameters of heavy industrial robots.",
    )
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"{__name__}.{name}").add_parser(subparsers)
    return parser


INTERRUPTED = 128 + signal.SIGINT
"""Exit status after Ctrl-C: 128 + SIGINT (130), as the shells report it; SIGTERM gives 143, SIGHUP 129."""

ENDING_SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))
"""Signals that end a run like Ctrl-C.  Python's default for them ends the process at once,
with no ``finally`` run: a writer's temporary file would be left beside its output."""


class _Ended(KeyboardInterrupt):
    """SIGTERM or SIGHUP raised where the run is, so that every writer cleans up as for Ctrl-C."""

    def __init__(self, number: int) -> None:
        super().__init__(signal.Signals(number).name)
        self.number = number


def _end(number: int, frame: object) -> None:
    raise _Ended(number)


@contextmanager
def _signals_end_the_run() -> Iterator[None]:
    """Turn :data:`ENDING_SIGNALS` into :class:`_Ended` for the run, then restore the handlers in force.

    A signal the caller ignores stays ignored: ``nohup bayescal ...`` must outlive its terminal.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {number: signal.signal(number, _end) for number in ENDING_SIGNALS if signal.getsignal(number) is not signal.SIG_IGN}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def main(
    argv: Sequence[str] | None = None, *, program: str = "bayescal", build: Callable[[], argparse.ArgumentParser] = build_parser
) -> int:
    """Run the command line and return the exit status (0 success, 2 bad input, 128 + the signal when interrupted).

    ``program`` names the command in its messages and ``build`` gives its parser: ``bayescal``'s by default; the
    research commands (``python -m bayescal_studies``) pass theirs, so that their errors, warnings, output and
    signals are handled as the product's.
    """
    # One BLAS thread unless the user asks for more, set before a command first imports numpy: every matrix
    # here is a few rows wide, and on a shared machine BLAS threads spin instead of helping (calibrate on the
    # Table III twin campaign: 3.5 s of CPU with one thread, 5.2 s with the default two, same process load).
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    forget_written()
    forget_reads()
    command = program
    with _signals_end_the_run():
        try:
            parser = build()
            try:
                args = parser.parse_args(argv)
            except SystemExit as exit:
                # A bad option value (status 2) or --help (status 0): the message is printed already.
                return exit.code if isinstance(exit.code, int) else 0
            command = f"{program} {args.command}"
            return _run(args, command)
        except KeyboardInterrupt as interrupt:
            # The writers rename whole files into place and remove their temporary files, so what was written is complete.
            kept = written_paths()
            try:
                print(f"{command}: interrupted; {'kept ' + ', '.join(kept) if kept else 'nothing written'}", file=sys.stderr)
            except OSError:
                pass  # the closed terminal of a SIGHUP takes no more lines; the status still says why
            return 128 + interrupt.number if isinstance(interrupt, _Ended) else INTERRUPTED


def _run(args: argparse.Namespace, command: str) -> int:
    """Run the parsed command, print its result or its one-line error, and return the exit status."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            output = args.run(args)
        except InputError as error:
            print(f"{command}: error: {error}", file=sys.stderr)
            return 2
        except RuntimeError as error:
            from bayescal.robot.stiffness import EquilibriumError

            if not isinstance(error, EquilibriumError):
                raise
            print(f"{command}: error: {_named_inputs(args)}: no static equilibrium of the loaded arm "
                  f"({error}); are the cell's compensator, loads and tool plausible?", file=sys.stderr)
            return 2
        except ValueError as error:
            # numpy's LinAlgError: an SVD or a factorisation that failed on a degenerate input.
            import numpy as np

            if not isinstance(error, np.linalg.LinAlgError):
                raise
            print(f"{command}: error: {_named_inputs(args)}: a linear-algebra step failed ({error}); "
                  "is a posterior degenerate (constant or repeated draws) or a plan without spread?", file=sys.stderr)
            return 2
        except OSError as error:
            # An output path that cannot be written is the user's to fix, not a bug.
            where = f"{error.filename}: " if error.filename is not None else ""
            print(f"{command}: error: {where}{error.strerror or error}", file=sys.stderr)
            return 2
    # Warnings go out before the result, so that a reader of a terminal sees them
    # above the table and a JSON consumer still gets clean stdout.
    messages = [str(warning.message) for warning in caught if issubclass(warning.category, UserWarning)]
    for message in dict.fromkeys(messages):
        print(f"{command}: warning: {message}", file=sys.stderr)
    sys.stderr.flush()
    try:
        if args.json:
            json.dump(output.payload, sys.stdout, indent=2, allow_nan=False)
            sys.stdout.write("\n")
        else:
            print(output.text)
        sys.stdout.flush()
    except BrokenPipeError:
        # A reader that stopped early (``| head``) is no error: the outputs are written already.
        # stdout goes to /dev/null so that the interpreter's own flush at exit does not fail again.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0


INPUT_OPTIONS = (
    ("campaign", "campaign"), ("points", "points"), ("--config", "config"), ("--plan", "plan"), ("--geometry", "geometry"),
    ("--calibration", "calibration"), ("--evaluate", "evaluate"), ("--mass-kg", "mass_kg"),
)
"""The arguments, across commands, that name an input or shape the loads: named when a solver fails."""


def _named_inputs(args: argparse.Namespace) -> str:
    """The inputs of this run that a failing solver depends on, e.g. ``--config cell.toml, --mass-kg 200 250``."""
    names = []
    for option, attribute in INPUT_OPTIONS:
        value = getattr(args, attribute, None)
        if value:
            names.append(f"{option} {' '.join(f'{v:g}' for v in value) if isinstance(value, list) else value}")
    return ", ".join(names) or "the inputs"


if __name__ == "__main__":
    sys.exit(main())
