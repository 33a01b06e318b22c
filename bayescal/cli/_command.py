"""What every subcommand shares: its common options and the shape of its result."""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any

__all__ = ["CommandOutput", "add_common_options"]

DEFAULT_SEED = 0


@dataclass(frozen=True)
class CommandOutput:
    """A subcommand's result: ``payload`` is printed by ``--json``, ``text`` otherwise."""

    payload: dict[str, Any]
    text: str = field(default="")


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--json`` and ``--seed``, which every subcommand takes."""
    parser.add_argument("--json", action="store_true", help="print a machine-readable result on stdout")
    parser.add_argument(
        "--seed",
        type=int,
        default=DEFAULT_SEED,
        help=f"seed of the random number generator; the same seed gives identical output (default {DEFAULT_SEED})",
    )
