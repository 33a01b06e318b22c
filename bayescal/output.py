"""The output guard and the atomic writers that every command's files and folders go through.

The contract, for every command (and every new one: call :func:`guard_outputs`
once before any work, then :func:`write_atomically` or :func:`write_folder`):

- before any work, every output is checked against every input and against the
  other outputs, by resolved path and by inode, so that no relative path,
  symlink or hard link lets a command write over what it reads or one output
  silently replace another;
- every reader of a file calls :func:`record_read` when it opens it, and a file
  a cell points to (its URDF, its reference table) is recorded when the cell is
  read, so the guard and the writers also refuse an output onto a file the
  command line does not name;
- a file is written to a temporary file beside its target and renamed in, so a
  full disk or an interrupt leaves the old file whole, and the error names the
  option and the file;
- a folder of files (a report, figures) is written into a staging folder, then
  renamed in whole when the folder is new, or its files renamed in together
  when it exists, with Ctrl-C (and SIGTERM, SIGHUP) held back during those renames;
- :func:`written_paths` says what a run has written, so that an interrupt can
  say what was kept.
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from os import PathLike
from pathlib import Path

from bayescal.errors import InputError

__all__ = [
    "check_output", "check_folder", "guard_outputs", "write_atomically", "write_folder", "written_paths", "forget_written",
    "record_read", "read_paths", "forget_reads",
]

PathText = str | PathLike[str]

_written: list[str] = []
"""Outputs renamed into place by this process since :func:`forget_written`, in order."""


def written_paths() -> list[str]:
    """The outputs written since the last :func:`forget_written` (the CLI's interrupt message names them)."""
    return list(_written)


def forget_written() -> None:
    """Start a new run's record of written outputs."""
    _written.clear()


_read: dict[str, str | None] = {}
"""Files read by this process since :func:`forget_reads`, by resolved path, with what each is (``None``: not said).

A record of the process, like :data:`_written`, rather than an argument: a table is
opened several calls below the command (a study reads its cell, the cell its URDF and
reference table), and a register passed down every reader's signature is one a new
reader can forget to pass on.  The CLI starts each run's record afresh."""


def record_read(path: PathText, what: str | None = None) -> None:
    """Record that this run reads ``path``: from now on no output may be written over it.

    Every reader calls it when it opens a file (or, for a file a cell points to,
    when the cell names it), so an output onto any input is refused whether or not
    the command line names that input.

    Parameters
    ----------
    path
        The file read.
    what
        What the file is, for the refusal, e.g. ``"the reference table the cell cell.toml points to"``;
        a later record of the same file keeps the first description given.
    """
    key = os.path.realpath(path)
    if _read.get(key) is None:
        _read[key] = what


def read_paths() -> list[str]:
    """The files (resolved paths) read since the last :func:`forget_reads`, in the order first read."""
    return list(_read)


def forget_reads() -> None:
    """Start a new run's record of the files it reads."""
    _read.clear()


def _same_file(a: Path, b: Path) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        # Hard links and case-insensitive file systems: same inode under another name.
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_output(option: str, path: PathText | None, inputs: Mapping[str, PathText | None]) -> None:
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
        When the output resolves to an input file or to a file this run has read
        (:func:`record_read`), also through a symlink, a relative path or a hard
        link; is a directory; lies in a folder that does not exist or cannot be
        written; or is a read-only file.
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
    _refuse_reads(option, path)
    if target.is_dir():
        raise InputError(f"{path} is a directory; expected the name of a file to write", source=option)
    folder = Path(os.path.realpath(target)).parent
    if not folder.is_dir():
        raise InputError(f"the output folder {folder} does not exist; create it first", source=option)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise InputError(f"cannot create files in the output folder {folder} (permission denied)", source=option)
    if target.exists() and not os.access(target, os.W_OK):
        raise InputError(f"{path} is read-only; make it writable or choose another output file", source=option)


def _refuse_reads(option: str, path: PathText) -> None:
    """Refuse an output that is a file this run has read (:func:`record_read`), under any name."""
    target = Path(path)
    # A copy: a reader on another thread (a study's workers) may record a file meanwhile.
    for source, what in list(_read.items()):
        if _same_file(target, Path(source)):
            alias = "" if os.path.realpath(target) == source else f" ({source})"
            raise InputError(
                f"{path} is {what or 'a file this command reads'}{alias}: writing there would destroy the input; "
                "choose another output file",
                source=option,
            )


def check_folder(option: str, path: PathText | None, names: Sequence[str], inputs: Mapping[str, PathText | None]) -> None:
    """Refuse an output folder that is a file, cannot be created, or would hold a file over an input.

    Parameters
    ----------
    option
        The option that names the folder, e.g. ``"--figures"``.
    path
        The folder (``None``: the command writes none); created when missing, its parent must exist.
    names
        The files the command writes into it, e.g. ``("residuals.png", "loo_pit.png")``.
    inputs
        What each input is and its path, as for :func:`check_output`.
    """
    if path is None:
        return
    if not str(path).strip():
        raise InputError("expected the name of a folder to write, got an empty text", source=option)
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        what = next((what for what, source in inputs.items() if source is not None and _same_file(folder, Path(source))), None)
        detail = f"{what} this command reads" if what else "a file"
        raise InputError(f"{path} is {detail}; expected a folder to write into", source=option)
    if folder.is_dir():
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputError(f"cannot write into the folder {path} (permission denied)", source=option)
        for name in names:
            check_output(option, folder / name, inputs)
        return
    parent = Path(os.path.realpath(folder)).parent
    if not parent.is_dir():
        raise InputError(f"the folder {parent} that should hold {path} does not exist; create it first", source=option)
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"cannot create the folder {path} in {parent} (permission denied)", source=option)


def guard_outputs(
    inputs: Mapping[str, PathText | None],
    files: Mapping[str, PathText | None] | None = None,
    folders: Mapping[str, tuple[PathText | None, Sequence[str]]] | None = None,
) -> None:
    """Check every output of a command against its inputs and against each other, before any work.

    Parameters
    ----------
    inputs
        What each input is (``"the campaign"``) and its path; ``None`` paths are skipped.
    files
        Each file output by its option (``{"-o": "plan.csv"}``); ``None``: not written.
    folders
        Each folder output by its option: its path and the names of the files written into it.

    Raises
    ------
    InputError
        Naming the option, when an output is an input or a file this run has read
        (:func:`record_read`) under any name, cannot be written, or is the same file
        as another output.
    """
    files = {option: path for option, path in (files or {}).items() if path is not None}
    folders = {option: entry for option, entry in (folders or {}).items() if entry[0] is not None}
    targets: list[tuple[str, Path]] = []
    for option, path in files.items():
        check_output(option, path, inputs)
        targets.append((option, Path(path)))
    for option, (path, names) in folders.items():
        check_folder(option, path, names, inputs)
        targets.append((option, Path(path)))
        targets += [(option, Path(path) / name) for name in names]
    for i, (option, path) in enumerate(targets):
        for other, other_path in targets[i + 1 :]:
            if other != option and _same_file(path, other_path):
                raise InputError(f"{path} is also the output of {other}: one would replace the other; give them different paths", source=option)


def _mode_for(target: Path, default: int = 0o666) -> int:
    """The permissions an output gets: those of the file it replaces, or the umask's for a new one."""
    if target.exists():
        return target.stat().st_mode & 0o777
    # mkstemp and mkdtemp create 0600/0700; a new output gets the usual permissions.
    umask = os.umask(0)
    os.umask(umask)
    return default & ~umask


HELD_SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))
"""The signals that end a run (Ctrl-C, a scheduler's or ``timeout``'s SIGTERM, a closed terminal's SIGHUP):
held back while outputs are renamed into place."""


@contextmanager
def _interrupts_held() -> Iterator[None]:
    """Hold back :data:`HELD_SIGNALS` while outputs are renamed into place; deliver the first once they all are.

    The signal is raised again under the handler that was in force, so it ends the
    run as it would have (``KeyboardInterrupt`` for Ctrl-C, the CLI's handler or the
    default termination for SIGTERM).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = {number: signal.signal(number, lambda number, frame: received.append(number)) for number in HELD_SIGNALS}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
    if received:
        signal.raise_signal(received[0])


def _failure(option: str, path: PathText, error: OSError) -> InputError:
    return InputError(f"cannot write {path} ({error.strerror or type(error).__name__}); nothing was replaced", source=option)


def write_atomically(option: str, path: PathText, write: Callable[[Path], None]) -> None:
    """Write a file through a temporary file in the same folder renamed into place.

    ``write(temporary_path)`` writes the content; the rename (``os.replace``) is
    atomic on one file system, so a reader, or a run interrupted at any moment,
    sees the old file or the new one complete.  A symlink is followed: its
    target is replaced, as an ordinary write through it would.

    Raises
    ------
    InputError
        When ``path`` is a file this run has read (:func:`record_read`: refused before
        anything is written), or when the file cannot be written (disk full,
        permission), naming ``option`` and ``path``.
    """
    _refuse_reads(option, path)
    target = Path(os.path.realpath(path))
    mode = _mode_for(target)
    try:
        handle, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=f".tmp{target.suffix}")
    except OSError as error:
        raise _failure(option, path, error) from None
    os.close(handle)
    temporary = Path(name)
    try:
        write(temporary)
        with temporary.open("rb+") as stream:
            os.fsync(stream.fileno())
        os.chmod(temporary, mode)
        with _interrupts_held():
            os.replace(temporary, target)
            _written.append(str(path))
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise _failure(option, path, error) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_folder(option: str, path: PathText, write: Callable[[Path], object]) -> list[Path]:
    """Write a folder of files through a staging folder, then put them all in place together.

    ``write(staging)`` writes the files into the staging folder.  A new folder
    is staged beside its place and renamed in whole; into an existing folder
    the files are staged in a hidden folder inside it and each renamed over its
    namesake (the folder's other files are left alone).  Ctrl-C is held back
    during the renames, so the folder holds all the old files or all the new ones.

    Returns
    -------
    list of Path
        The files written, under ``path``, sorted by name.

    Raises
    ------
    InputError
        When the folder or one of the files is a file this run has read (:func:`record_read`),
        or the files cannot be written (disk full, permission), naming ``option`` and ``path``;
        the folder is then as it was.
    """
    _refuse_reads(option, path)
    folder = Path(path)
    exists = folder.is_dir()
    home = folder if exists else Path(os.path.realpath(folder)).parent
    try:
        staging = Path(tempfile.mkdtemp(dir=home, prefix=f".{folder.name}.", suffix=".tmp"))
    except OSError as error:
        raise _failure(option, path, error) from None
    try:
        write(staging)
        names = sorted(entry.name for entry in staging.iterdir())
        for name in names:
            _refuse_reads(option, folder / name)
        for name in names:
            with (staging / name).open("rb+") as stream:
                os.fsync(stream.fileno())
        with _interrupts_held():
            if exists:
                for name in names:
                    os.replace(staging / name, folder / name)
                staging.rmdir()
            else:
                os.chmod(staging, _mode_for(folder, 0o777))
                os.rename(staging, folder)
            _written.extend(str(folder / name) for name in names)
    except OSError as error:
        shutil.rmtree(staging, ignore_errors=True)
        raise _failure(option, path, error) from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return [folder / name for name in names]
