"""What a controller program is to the compensation: its targets, the frames they are given in, and how to rewrite them.

The contract, shared by every language (:mod:`~bayescal.controllers.krl`,
:mod:`~bayescal.controllers.rapid`): a reader returns a :class:`ControllerProgram`
whose :attr:`~ControllerProgram.targets` are the declared targets some motion
statement moves to, each with the tool and base frame of that motion (SI), and
whose :meth:`~ControllerProgram.write` rewrites the declarations of the targets
it is given, and nothing else: every other line, and every part of a rewritten
line it does not change, is written back byte for byte (files are read as
Latin-1, which maps every byte to one character and back).  A statement the
reader does not understand and that moves nothing is passed through and counted
in :attr:`~ControllerProgram.unsupported`; one that moves the robot or changes
a frame in a way the reader cannot follow is an error, since passing it through
would leave a target uncompensated or solved in the wrong frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bayescal.errors import InputError
from bayescal.output import record_read

__all__ = ["Target", "Rewrite", "ControllerProgram", "read_lines", "IDENTITY", "same_frame", "set_rotations"]

ENCODING = "latin-1"
"""Every byte is one character: a file read and written back is unchanged, whatever its code page."""

IDENTITY = (np.eye(3), np.zeros(3))
"""The frame that is its parent: KRL's ``$NULLFRAME``, RAPID's ``tool0`` and ``wobj0``."""

FRAME_MATCH = 1e-12
"""How close (m, and rotation matrix entries) two frames of one target's motions must be to be the same frame."""


@dataclass
class Target:
    """A declared target some motion statement moves to.

    Attributes
    ----------
    name : str
    cartesian : bool
        True for a pose (KRL ``POS``/``E6POS``, RAPID ``robtarget``), False for joints (``AXIS``/``E6AXIS``, ``jointtarget``).
    rotation, origin : numpy.ndarray
        ``(3, 3)`` and ``(3,)`` (m) the pose in its base frame (Cartesian targets; zeros otherwise).
    orientation : numpy.ndarray
        The orientation as written: ``A, B, C`` (deg, KRL) or the unit quaternion ``w, x, y, z`` (RAPID); empty for joints.
    q : numpy.ndarray
        ``(6,)`` the joints, rad (joint targets; NaN otherwise).
    configuration : dict
        The language's configuration fields as integers: ``S``, ``T`` (KRL) or ``cf1``, ``cf4``, ``cf6``, ``cfx`` (RAPID).
    tool, base : tuple
        ``(rotation, origin)`` of the motion's tool in the flange frame and of its base in the robot's base frame (m).
    source : str
        The file that declares it.
    line, column : int
        Where its value starts in that file (1-based).
    tool_name, base_name : str
        How the motion names them (for error messages).
    """

    name: str
    cartesian: bool
    rotation: np.ndarray
    origin: np.ndarray
    q: np.ndarray
    configuration: dict
    source: str
    line: int
    column: int
    tool: tuple | None = None
    base: tuple | None = None
    tool_name: str = ""
    base_name: str = ""
    orientation: np.ndarray = field(default_factory=lambda: np.empty(0))


@dataclass(frozen=True)
class Rewrite:
    """A target's compensated value, in the language's units (mm, deg, quaternion), with the comment to append.

    Attributes
    ----------
    values : dict
        The fields to replace, by the language's name (``X`` … ``C``, ``S``, ``T``, ``A1`` …; ``x`` … ``q4``, ``cf1`` …).
    comment : str
        Text of the comment that ends the rewritten line.
    """

    values: dict
    comment: str


@dataclass
class ControllerProgram:
    """A program read by a language's reader (see the module's contract).

    Attributes
    ----------
    language : str
        ``"KRL"`` or ``"RAPID"``.
    files : dict
        Each file's role (``"src"``, ``"dat"``, ``"mod"``) and its lines as read, line endings kept.
    paths : dict
        Each role's path.
    targets : list of Target
        In the order first moved to.
    unsupported : int
        Statements passed through without being understood.
    motions : int
        Motion statements read.
    """

    language: str
    files: dict[str, list[str]]
    paths: dict[str, str]
    targets: list[Target] = field(default_factory=list)
    unsupported: int = 0
    motions: int = 0
    # For each target name: (role, line index, {field: (start, end, text)}) where its fields' values are written.
    spans: dict = field(default_factory=dict, repr=False)

    @property
    def source(self) -> str:
        """The main file (the ``.src`` or the ``.mod``)."""
        return self.paths.get("src") or self.paths["mod"]

    def rewritten(self, rewrites: dict[str, Rewrite], comment_mark: str, format_value) -> dict[str, str]:
        """Each role's text with the targets of ``rewrites`` replaced, each changed line ending with ``comment_mark`` and its comment.

        ``format_value(field, value)`` writes one field's value as the language writes it.
        """
        out = {}
        for role, lines in self.files.items():
            lines = list(lines)
            for name, rewrite in rewrites.items():
                where, index, fields = self.spans[name]
                if where != role:
                    continue
                text = lines[index]
                body = text.rstrip("\r\n")
                ending = text[len(body):]
                for key, (start, end, _) in sorted(fields.items(), key=lambda item: -item[1][0]):
                    if key in rewrite.values:
                        body = body[:start] + format_value(key, rewrite.values[key]) + body[end:]
                lines[index] = f"{body} {comment_mark} {rewrite.comment}{ending}"
            out[role] = "".join(lines)
        return out


def read_lines(path: str | Path, what: str) -> list[str]:
    """The lines of ``path`` (line endings kept), recorded as read."""
    file = Path(path)
    if not file.is_file():
        raise InputError(f"{what} not found" if not file.is_dir() else f"is a folder; expected {what}", source=str(path))
    record_read(file, what)
    with open(file, encoding=ENCODING, newline="") as handle:
        return handle.read().splitlines(keepends=True)


def set_rotations(targets: list[Target], rotations) -> None:
    """Give the Cartesian ``targets`` their rotations, converted at once from their :attr:`Target.orientation`
    by ``rotations`` (``(N, k)`` → ``(N, 3, 3)``): one array operation, not one per target."""
    cartesian = [target for target in targets if target.cartesian]
    if cartesian:
        for target, rotation in zip(cartesian, rotations(np.array([target.orientation for target in cartesian]))):
            target.rotation = rotation


def same_frame(a: tuple, b: tuple) -> bool:
    """Whether two ``(rotation, origin)`` frames are the same to :data:`FRAME_MATCH`."""
    return bool(np.allclose(a[0], b[0], atol=FRAME_MATCH, rtol=0) and np.allclose(a[1], b[1], atol=FRAME_MATCH, rtol=0))
