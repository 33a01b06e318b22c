"""What every subcommand shares: its common options, the checks of its option values,
the safe writing of its output file and the shape of its result.

Every output file goes through :func:`check_output` before any work is done and
through :func:`write_atomically` at the end: a command never writes over one of
its own inputs (whatever path, relative path, symlink or hard link names it),
and an interrupted run leaves the old file or the new one, never half of one.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from bayescal.errors import InputError

__all__ = [
    "CommandOutput",
    "add_common_options",
    "whole_number",
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


def _same_file(a: Path, b: Path) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        # Hard links and case-insensitive file systems: same inode under another name.
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_output(option: str, path: str | PathLike[str] | None, inputs: Mapping[str, str | PathLike[str] | None]) -> None:
    """Refuse an output path that is one of the command's inputs or that cannot be written.

    Parameters
    ----------
    option
        The option that names the output, e.g. ``"--posterior"``; errors name it.
    path
        The output path (``None``: the command writes nothing).
    inputs
        What each input is (e.g. ``"the campaign"``) and its path; ``None`` paths are skipped.

    Raises
    ------
    InputError
        When the output resolves to an input file (also through a symlink, a
        relative path or a hard link), is a directory, lies in a folder that
        does not exist or cannot be written, or is a read-only file.
    """
    if path is None:
        return
    if not str(path).strip():
        raise InputError("expected the name of a file to write, got an empty text", source=option)
    target = Path(path)
    for what, source in inputs.items():
        if source is not None and _same_file(target, Path(source)):
            alias = "" if str(source) == str(path) else f" ({source})"
            raise InputError(
                f"{path} is {what}{alias} this command reads: writing there would destroy the input; "
                "choose another output file",
                source=option,
            )
    if target.is_dir():
        raise InputError(f"{path} is a directory; expected the name of a file to write", source=option)
    folder = Path(os.path.realpath(target)).parent
    if not folder.is_dir():
        raise InputError(f"the output folder {folder} does not exist; create it first", source=option)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot create files in the output folder {folder} (permission denied)", source=option)
    if target.exists() and not os.access(target, os.W_OK):
        raise InputError(f"{path} is read-only; make it writable or choose another output file", source=option)


def write_atomically(option: str, path: str | PathLike[str], write: Callable[[Path], None]) -> None:
    """Write a file through a temporary file in the same folder renamed into place.

    ``write(temporary_path)`` writes the content; the rename (``os.replace``) is
    atomic on one file system, so a reader, or a run interrupted at any moment,
    sees the old file or the new one complete.  A symlink is followed: its
    target is replaced, as an ordinary write through it would.

    Raises
    ------
    InputError
        When the file cannot be written (disk full, permission), naming ``option``.
    """
    target = Path(os.path.realpath(path))
    if target.exists():
        mode = target.stat().st_mode & 0o777
    else:
        # mkstemp creates the file 0600; a new output gets the usual permissions.
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    try:
        handle, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=f".tmp{target.suffix}")
    except OSError as error:
        raise InputError(f"cannot write {path} ({error.strerror or type(error).__name__})", source=option) from None
    os.close(handle)
    temporary = Path(name)
    try:
        write(temporary)
        with temporary.open("rb+") as stream:
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
        os.replace(temporary, target)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise InputError(f"cannot write {path} ({error.strerror or type(error).__name__})", source=option) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
