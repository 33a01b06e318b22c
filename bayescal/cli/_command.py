"""What every subcommand shares: its common options, the checks of its option values
and the shape of its result.

The output guard and the atomic writers live in :mod:`bayescal.output`;
:func:`check_output` and :func:`write_atomically` are re-exported here.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

from bayescal.errors import InputError
from bayescal.output import check_output, write_atomically

__all__ = [
    "CommandOutput",
    "add_common_options",
    "whole_number",
    "options_for",
    "check_output",
    "write_atomically",
]

DEFAULT_SEED = 0


@dataclass(frozen=True)
class CommandOutput:
    """A subcommand's result: ``payload`` is printed by ``--json``, ``text`` otherwise."""

    payload: dict[str, Any]
    text: str = field(default="")


def whole_number(minimum: int, what: str = "") -> Callable[[str], int]:
    """An argparse ``type`` accepting a whole number ``>= minimum`` written with digits only.

    ``int()`` alone accepts ``"1_000"`` and ``" 7"``; a count or a seed is written
    with an optional sign and digits, nothing else.
    """

    def parse(text: str) -> int:
        expected = f"a whole number >= {minimum}" + (f" ({what})" if what else "")
        stripped = text.strip()
        digits = stripped[1:] if stripped[:1] in "+-" else stripped
        if not (digits.isascii() and digits.isdigit()):
            raise argparse.ArgumentTypeError(f"expected {expected}, got '{text}'")
        value = int(stripped)
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {expected}, got {value}")
        return value

    parse.__name__ = "whole number"
    return parse


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--json`` and ``--seed``, which every subcommand takes."""
    parser.add_argument("--json", action="store_true", help="print a machine-readable result on stdout")
    parser.add_argument(
        "--seed",
        type=whole_number(0, "NumPy seeds are non-negative"),
        default=DEFAULT_SEED,
        help=f"seed of the random number generator, a whole number >= 0; the same seed gives identical output "
        f"(default {DEFAULT_SEED})",
    )


@contextmanager
def options_for(flags: Mapping[str, str]) -> Iterator[None]:
    """Name this command's option in a library error about one of its own arguments.

    The library names its arguments (``InputError(..., source="angles")``); within
    ``with options_for({"angles": "--max-angles"}):`` such an error is raised again
    with ``source="--max-angles"``.  Errors about files pass unchanged.
    """
    try:
        yield
    except InputError as error:
        if error.source not in flags:
            raise
        raise InputError(error.what, source=flags[error.source], line=error.line, column=error.column) from None
