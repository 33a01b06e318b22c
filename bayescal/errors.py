"""Errors raised on bad input.

Every problem a user can cause with a file or an option is an :class:`InputError`
whose message fits on one line and names the file, the line and the column, so
that the CLI can print it and exit with status 2 instead of a traceback.
"""

from __future__ import annotations

from os import PathLike

__all__ = ["InputError", "NotIdentifiableWarning"]


class InputError(ValueError):
    """A user-supplied file or value that cannot be used.

    Parameters
    ----------
    what
        What is wrong and what was expected, e.g. ``"expected a number in mm, got 'abc'"``.
    source
        The file (or option) the bad value came from.
    line
        1-based line number in ``source`` (the header is line 1 of a CSV file).
    column
        The column or key holding the bad value.
    """

    def __init__(
        self,
        what: str,
        *,
        source: str | PathLike[str] | None = None,
        line: int | None = None,
        column: str | None = None,
    ) -> None:
        self.what = what
        self.source = None if source is None else str(source)
        self.line = line
        self.column = column
        where = []
        if self.source is not None:
            where.append(self.source if line is None else f"{self.source}:{line}")
        elif line is not None:
            where.append(f"line {line}")
        if column is not None:
            where.append(f"column '{column}'")
        prefix = ", ".join(where)
        message = f"{prefix}: {what}" if prefix else what
        super().__init__(" ".join(message.split()))


class NotIdentifiableWarning(UserWarning):
    """The data cannot determine a parameter; it is reported, not estimated."""
