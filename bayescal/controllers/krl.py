"""KUKA KRL programs: a ``.src`` of motions and its ``.dat`` of targets.

The subset read (docs/controllers.md lists it with its sources):

* in the ``.dat``: ``DECL`` (optionally ``GLOBAL``) of ``E6POS``, ``POS`` (Cartesian
  targets: ``X, Y, Z`` mm, ``A, B, C`` deg, status ``S`` and turn ``T``, decimal or
  ``'B…'``), ``E6AXIS``, ``AXIS`` (joint targets ``A1 … A6``, deg) and ``FRAME``
  (``X … C``, for ``$BASE`` and ``$TOOL``), one declaration per line; other lines are data the
  compensation does not touch;
* in the ``.src``: ``PTP``, ``LIN`` to a declared target, ``CIRC`` to an auxiliary and an
  end target (the approximation and ``CA`` options after them are kept), and
  ``$BASE =``, ``$TOOL =`` a ``FRAME`` literal, a declared ``FRAME`` or ``$NULLFRAME``.

Comments, blank lines, ``DEF``/``END``, ``&`` headers and ``;FOLD`` lines are the
program's structure; any other statement is passed through and counted, except
those that move the robot or set a frame in a way this reader cannot follow
(relative and spline motions, inline targets, ``BAS(#TOOL…)``, ``BAS(#BASE…)``,
``FDAT_ACT``, a frame from ``TOOL_DATA``/``BASE_DATA``), which are errors.
"""

from __future__ import annotations

import re
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.controllers.poses import kuka_rotation
from bayescal.controllers.program import IDENTITY, ControllerProgram, Target, read_lines, same_frame, set_rotations
from bayescal.errors import InputError
from bayescal.units import DEG, MM

__all__ = ["read_krl", "write_krl", "status_text", "COMMENT"]

COMMENT = ";"
"""KRL's comment mark: the rest of the line is a comment."""

_DECLARATION = re.compile(r"^(\s*(?:GLOBAL\s+)?(?:DECL\s+)?(E6POS|POS|E6AXIS|AXIS|FRAME)\s+)([A-Za-z_$][\w$]*)\s*=\s*\{", re.IGNORECASE)
_COMPONENT = re.compile(r"\s*([A-Za-z_]\w*)\s+('[^']*'|[^,}\s]+)\s*(?:,|(?=\}))")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?$")
_MOTION = re.compile(r"^\s*(PTP|LIN|CIRC)(?=[\s{])\s*(.*)$", re.IGNORECASE)
_FRAME_SET = re.compile(r"^\s*\$(BASE|TOOL)\s*=\s*(.*?)\s*$", re.IGNORECASE)
_REFUSED_MOTION = re.compile(r"^\s*(PTP_REL|LIN_REL|CIRC_REL|SPTP|SLIN|SCIRC|SPLINE|SPTP_REL|SLIN_REL|SCIRC_REL|ASYPTP)\b", re.IGNORECASE)
_REFUSED_FRAME = re.compile(r"^\s*(FDAT_ACT\s*=|BAS\s*\(\s*#(TOOL|BASE|FRAMES)\b)", re.IGNORECASE)
_STRUCTURE = re.compile(r"^\s*(;|&|$|DEF\b|DEFFCT\b|END\b|ENDFCT\b|INI\b)", re.IGNORECASE)
_APPROXIMATION = re.compile(r"^(C_DIS|C_PTP|C_VEL|C_ORI|C_SPL)$", re.IGNORECASE)

_CARTESIAN = ("X", "Y", "Z", "A", "B", "C")
_AXES = ("A1", "A2", "A3", "A4", "A5", "A6")


def _code(line: str) -> str:
    """The line without its comment."""
    return line.split(";", 1)[0]


def _aggregate(line: str, start: int, source: str, number: int) -> dict[str, tuple[int, int, str]]:
    """The components of the ``{…}`` opening at ``start`` - 1: name (upper case) → (start, end, text)."""
    end = line.find("}", start)
    if end < 0:
        raise InputError("the declaration's '{' is not closed on its line (one declaration per line)", source=source, line=number, column=str(start))
    fields: dict[str, tuple[int, int, str]] = {}
    position = start
    while position < end:
        match = _COMPONENT.match(line, position, end + 1)
        if not match:
            raise InputError(f"expected 'NAME value' in the aggregate, got '{line[position:end].strip()[:30]}'", source=source, line=number, column=str(position + 1))
        name, value = match.group(1).upper(), match.group(2)
        if name in fields:
            raise InputError(f"'{name}' is given twice", source=source, line=number, column=str(match.start(1) + 1))
        fields[name] = (match.start(2), match.end(2), value)
        position = match.end()
    return fields


def _number(fields, name: str, source: str, number: int, *, required: bool = True) -> float | None:
    if name not in fields:
        if required:
            raise InputError(f"missing '{name}'", source=source, line=number, column=name)
        return None
    start, _, text = fields[name]
    if not _NUMBER.match(text):
        raise InputError(f"expected a number for '{name}', got '{text}'", source=source, line=number, column=str(start + 1))
    return float(text)


def _status(fields, name: str, source: str, number: int) -> int:
    """``S`` or ``T``, decimal or ``'B0101'``; missing is an error: the target would not name its configuration."""
    if name not in fields:
        raise InputError(
            "a Cartesian target without 'S' and 'T' leaves the arm's configuration to the controller; give the status "
            "and turn the target was taught with",
            source=source,
            line=number,
            column=name,
        )
    start, _, text = fields[name]
    binary = re.fullmatch(r"'B([01]+)'", text, re.IGNORECASE)
    if binary:
        return int(binary.group(1), 2)
    if not text.isdigit():
        raise InputError(f"expected a whole number or 'B…' bits for '{name}', got '{text}'", source=source, line=number, column=str(start + 1))
    return int(text)


def _frame_of(fields, source: str, number: int) -> tuple[np.ndarray, np.ndarray]:
    values = [_number(fields, name, source, number) for name in _CARTESIAN]
    return kuka_rotation(np.array([values[3:]]))[0], np.array(values[:3]) * MM


def _dat_path(src: Path) -> Path:
    for suffix in (".dat", ".DAT", ".Dat"):
        if src.with_suffix(suffix).is_file():
            return src.with_suffix(suffix)
    raise InputError(f"the program's data file {src.with_suffix('.dat').name} is not beside it (a .src is read with its .dat)", source=str(src))


def read_krl(src: str | PathLike[str]) -> ControllerProgram:
    """Read a KRL ``.src`` and the ``.dat`` of the same name beside it.

    Raises
    ------
    InputError
        Naming the file, line and column (the character, 1-based) of what cannot be read: a
        malformed declaration, a Cartesian target without ``S``/``T``, a motion to an undeclared
        target, an unsupported motion or frame statement, a Cartesian motion before ``$BASE``
        and ``$TOOL`` are set, or a target moved to with two different frames.
    """
    src_path = Path(src)
    src_lines = read_lines(src_path, "the program")
    dat_path = _dat_path(src_path)
    dat_lines = read_lines(dat_path, "the program's data file")
    program = ControllerProgram(language="KRL", files={"src": src_lines, "dat": dat_lines}, paths={"src": str(src_path), "dat": str(dat_path)})
    declared: dict[str, tuple] = {}
    for index, line in enumerate(dat_lines):
        match = _DECLARATION.match(_code(line))
        if match:
            kind, name = match.group(2).upper(), match.group(3).upper()
            fields = _aggregate(line, match.end(), str(dat_path), index + 1)
            declared[name] = (kind, fields, index, match.start(3) + 1)
    frames = {"BASE": None, "TOOL": None}
    names = {"BASE": "", "TOOL": ""}
    targets: dict[str, Target] = {}
    source = str(src_path)
    for index, line in enumerate(src_lines):
        number = index + 1
        code = _code(line)
        if _STRUCTURE.match(code):
            continue
        if _REFUSED_MOTION.match(code) or _REFUSED_FRAME.match(code):
            word = code.strip().split("(")[0].split("=")[0].split()[0]
            raise InputError(
                f"'{word}' is not supported: it moves the robot or sets a frame this reader cannot follow (docs/controllers.md)",
                source=source, line=number, column=str(len(code) - len(code.lstrip()) + 1),
            )
        frame_set = _FRAME_SET.match(code)
        if frame_set:
            which = frame_set.group(1).upper()
            frames[which] = _frame_value(frame_set.group(2), declared, source, number, code.index(frame_set.group(2)) + 1, dat_path)
            names[which] = frame_set.group(2)
            continue
        motion = _MOTION.match(code)
        if not motion:
            program.unsupported += 1
            continue
        program.motions += 1
        _add_motion_targets(motion, code, number, source, dat_path, declared, (frames, names), targets, program)
    program.targets = list(targets.values())
    set_rotations(program.targets, kuka_rotation)
    return program


def _add_motion_targets(motion: re.Match, code: str, number: int, source: str, dat_path: Path, declared: dict[str, tuple],
                        frame_state: tuple[dict, dict], targets: dict[str, Target], program: ControllerProgram) -> None:
    """Check one motion statement and add the targets it moves to (once each, in the ``$BASE``/``$TOOL`` then set)."""
    frames, names = frame_state
    verb = motion.group(1).upper()
    if "{" in motion.group(2):
        raise InputError("an inline target is not supported: declare it in the .dat and move to its name", source=source, line=number, column=str(code.index("{") + 1))
    arguments = [part.strip() for part in motion.group(2).split(",")]
    wanted = 2 if verb == "CIRC" else 1
    moved = arguments[:wanted]
    for part in arguments[wanted:]:
        if part and not _APPROXIMATION.match(part) and not re.match(r"^CA\s+\S+$", part, re.IGNORECASE):
            raise InputError(f"unexpected '{part}' after the {verb} target", source=source, line=number, column=str(code.find(part) + 1))
    if len(moved) < wanted or not all(moved):
        raise InputError(f"{verb} needs {'an auxiliary and an end target' if wanted == 2 else 'a target'}", source=source, line=number)
    for name_text in moved:
        column = code.find(name_text) + 1
        name = name_text.split()[0].upper()
        if name not in declared or declared[name][0] == "FRAME":
            raise InputError(f"'{name_text}' is not a target declared in {dat_path.name}", source=source, line=number, column=str(column))
        kind, fields, dat_index, dat_column = declared[name]
        cartesian = kind in ("E6POS", "POS")
        if not cartesian and verb != "PTP":
            raise InputError(f"{verb} moves to a Cartesian target; '{name_text}' is an {kind}", source=source, line=number, column=str(column))
        if frames["TOOL"] is None or (cartesian and frames["BASE"] is None):
            missing = "$TOOL" if frames["TOOL"] is None else "$BASE"
            raise InputError(f"{verb} {name_text} comes before {missing} is set: the target's frame is unknown", source=source, line=number, column=str(column))
        base = frames["BASE"] if cartesian else IDENTITY
        if name in targets:
            seen = targets[name]
            if not (same_frame(seen.tool, frames["TOOL"]) and same_frame(seen.base, base)):
                raise InputError(
                    f"target {name_text} is moved to with another $TOOL or $BASE than at its first motion: one declaration "
                    "cannot carry two compensated poses; declare a target per frame",
                    source=source, line=number, column=str(column),
                )
            continue
        targets[name] = _target(name, kind, fields, str(dat_path), dat_index + 1, dat_column, frames["TOOL"], base, names)
        program.spans[name] = ("dat", dat_index, fields)


def _frame_value(text: str, declared, source: str, number: int, column: int, dat_path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A ``$BASE``/``$TOOL`` value: a ``FRAME`` literal, a declared ``FRAME``, or ``$NULLFRAME``."""
    if text.upper() == "$NULLFRAME":
        return IDENTITY
    if text.startswith("{"):
        fields = _aggregate(text, 1, source, number)
        return _frame_of(fields, source, number)
    key = text.upper()
    if key in declared and declared[key][0] == "FRAME":
        _, fields, dat_index, _ = declared[key]
        return _frame_of(fields, str(dat_path), dat_index + 1)
    raise InputError(
        f"'{text}' is not a FRAME literal, $NULLFRAME or a FRAME declared in {dat_path.name} (TOOL_DATA and BASE_DATA live "
        "in the controller, not in the program)",
        source=source, line=number, column=str(column),
    )


def _target(name, kind, fields, source, line, column, tool, base, names) -> Target:
    if kind in ("E6POS", "POS"):
        values = [_number(fields, key, source, line) for key in _CARTESIAN]
        configuration = {"S": _status(fields, "S", source, line), "T": _status(fields, "T", source, line)}
        return Target(
            name=name, cartesian=True, rotation=np.eye(3), origin=np.array(values[:3]) * MM, orientation=np.array(values[3:]),
            q=np.full(6, np.nan), configuration=configuration, source=source, line=line, column=column,
            tool=tool, base=base, tool_name=names["TOOL"], base_name=names["BASE"],
        )
    q = np.array([_number(fields, key, source, line) for key in _AXES]) * DEG
    return Target(
        name=name, cartesian=False, rotation=np.zeros((3, 3)), origin=np.zeros(3), q=q, configuration={},
        source=source, line=line, column=column, tool=tool, base=IDENTITY, tool_name=names["TOOL"],
    )


def _format(decimals: int):
    def write(key: str, value) -> str:
        if key in ("S", "T"):
            return value
        return f"{value:.{decimals}f}"

    return write


def write_krl(program: ControllerProgram, rewrites: dict, decimals: int) -> dict[str, str]:
    """The ``src`` and ``dat`` texts with ``rewrites`` (:class:`~bayescal.controllers.program.Rewrite` by target name)
    applied to the ``.dat``; ``S`` and ``T`` are given as text, written in the form the file used."""
    return program.rewritten(rewrites, COMMENT, _format(decimals))


def status_text(old: str, value: int) -> str:
    """``value`` written as ``old`` was: ``'B…'`` with as many bits, or decimal."""
    binary = re.fullmatch(r"'B([01]+)'", old, re.IGNORECASE)
    if binary:
        return f"'B{value:0{len(binary.group(1))}b}'"
    return str(value)
