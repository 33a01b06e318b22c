"""ABB RAPID programs: a module (``.mod``) of data declarations and move instructions.

The subset read (docs/controllers.md lists it with its sources):

* declarations ``CONST``/``PERS``/``VAR`` (optionally ``LOCAL`` or ``TASK``) of
  ``robtarget`` (``[[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,…,eax_f]]``: mm and a
  unit quaternion ``w, x, y, z``), ``jointtarget`` (``[[rax_1,…,rax_6],[eax…]]``: deg),
  ``tooldata`` (held by the robot: ``[TRUE,[[x,y,z],[q…]],[load…]]``) and ``wobjdata``
  (not held by the robot, fixed user frame: ``[FALSE,TRUE,"",[[uframe]],[[oframe]]]``),
  one declaration per line;
* ``MoveL``, ``MoveJ`` to a declared ``robtarget``, ``MoveC`` to a circle point and an end
  point, ``MoveAbsJ`` to a ``jointtarget``, with their tool and optional ``\\WObj``
  (``tool0`` and ``wobj0`` are the flange and the robot's base frame).

Comments (``!``), blank lines and the module's structure (``MODULE``, ``PROC``,
``ENDPROC``, ``ENDMODULE``, ``%%%`` headers) are kept; any other statement is passed
through and counted, except other move or search instructions and targets written
inline or through a function (``Offs``, ``RelTool``), which are errors.
"""

from __future__ import annotations

import re
from os import PathLike
from pathlib import Path

import numpy as np

from bayescal.controllers.poses import compose, quaternion_rotation
from bayescal.controllers.program import IDENTITY, ControllerProgram, Target, read_lines, same_frame, set_rotations
from bayescal.errors import InputError
from bayescal.units import DEG, MM

__all__ = ["read_rapid", "write_rapid", "COMMENT", "QUATERNION_NORM_TOLERANCE"]

COMMENT = "!"
"""RAPID's comment mark: the rest of the line is a comment."""

QUATERNION_NORM_TOLERANCE = 1e-3
"""How far a written quaternion's norm may be from 1: ABB's controllers normalise within about this (six
decimals of each component leave it 1e-6 off); angles written in its place are orders of magnitude beyond."""

_DECLARATION = re.compile(
    r"^\s*(?:(?:LOCAL|TASK)\s+)?(CONST|PERS|VAR)\s+(robtarget|jointtarget|tooldata|wobjdata)\s+([A-Za-z]\w*)\s*:=\s*(?=\[)", re.IGNORECASE
)
_MOVE = re.compile(r"^\s*(MoveL|MoveJ|MoveC|MoveAbsJ)\b\s*(.*?)\s*;\s*$", re.IGNORECASE)
_REFUSED = re.compile(r"^\s*(Move\w+|Search\w+|Trigg\w+|Arc\w+|CirPathMode|Offs|RelTool)\b", re.IGNORECASE)
_STRUCTURE = re.compile(r"^\s*(!|%%%|$|MODULE\b|ENDMODULE\b|PROC\b|ENDPROC\b|LOCAL\s+PROC\b|ERROR\b|BACKWARD\b|UNDO\b)", re.IGNORECASE)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_WORD = re.compile(r"[A-Za-z_]\w*|\"[^\"]*\"")


def _code(line: str) -> str:
    """The line without its comment (a ``!`` outside a string)."""
    if "!" not in line:
        return line
    if '"' not in line:
        return line.split("!", 1)[0]
    inside = False
    for i, char in enumerate(line):
        if char == '"':
            inside = not inside
        elif char == "!" and not inside:
            return line[:i]
    return line


_TOKEN = re.compile(r"\s*(?:(\[)|(\])|(,)|([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[A-Za-z_]\w*|\"[^\"]*\"))")


def _literal(line: str, start: int, source: str, number: int):
    """The nested ``[…]`` opening at ``start``: lists of leaves ``(text, start, end)``, and where it ends."""

    def fail(at: int, expected: str):
        raise InputError(f"expected {expected}, got '{line[at:at + 12].strip() or 'the end of the line'}'", source=source, line=number, column=str(at + 1))

    stack: list[list] = []
    at = start
    expect_value = True
    while True:
        token = _TOKEN.match(line, at)
        if not token:
            fail(at, "a number, a name, '[', ',' or ']' (one declaration per line)")
        opening, closing, comma, leaf = token.groups()
        at = token.end()
        if expect_value:
            if opening:
                stack.append([])
                continue
            if not leaf:
                fail(token.start(), "a number, a name or '['")
            if not stack:
                return (leaf, token.start(4), token.end(4)), at
            stack[-1].append((leaf, token.start(4), token.end(4)))
            expect_value = False
            continue
        if comma and stack:
            expect_value = True
            continue
        if closing and stack:
            done = stack.pop()
            if not stack:
                return done, at
            stack[-1].append(done)
            continue
        fail(token.start(), "',' or ']' (one declaration per line)")


def _numbers(node, count: int, what: str, source: str, number: int) -> list[tuple[str, int, int]]:
    """The ``count`` numeric leaves of a list node."""
    if not isinstance(node, list) or len(node) != count or any(isinstance(leaf, list) or not _NUMBER.fullmatch(leaf[0]) for leaf in node):
        column = _first_column(node)
        raise InputError(f"expected {what}: [{count} numbers]", source=source, line=number, column=str(column))
    return node


def _first_column(node) -> int:
    while isinstance(node, list) and node:
        node = node[0]
    return node[1] + 1 if isinstance(node, tuple) else 1


def _pose(node, what: str, source: str, number: int, *, fields: dict | None = None):
    """A ``pose`` ``[[x,y,z],[q1..q4]]``: (rotation, origin in m); with ``fields``, (unit quaternion, origin), the
    leaves' spans recorded in ``fields`` (a target's rotation is made with all the others': :func:`set_rotations`)."""
    if not isinstance(node, list) or len(node) != 2:
        raise InputError(f"expected {what} as [[x,y,z],[q1,q2,q3,q4]]", source=source, line=number, column=str(_first_column(node)))
    trans = _numbers(node[0], 3, f"{what}'s position in mm", source, number)
    rot = _numbers(node[1], 4, f"{what}'s quaternion", source, number)
    quaternion = np.array([float(leaf[0]) for leaf in rot])
    norm = np.linalg.norm(quaternion)
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InputError(
            f"{what}'s quaternion [{', '.join(leaf[0] for leaf in rot)}] has norm {norm:.4g}, not 1: RAPID orientations are unit "
            "quaternions [w, x, y, z], not angles",
            source=source, line=number, column=str(rot[0][1] + 1),
        )
    origin = np.array([float(leaf[0]) for leaf in trans]) * MM
    if fields is not None:
        for key, leaf in zip(("x", "y", "z", "q1", "q2", "q3", "q4"), trans + rot):
            fields[key] = (leaf[1], leaf[2], leaf[0])
        return quaternion / norm, origin
    return quaternion_rotation((quaternion / norm)[None])[0], origin


def _flag(leaf, source: str, number: int) -> bool:
    if isinstance(leaf, list) or leaf[0].upper() not in ("TRUE", "FALSE"):
        raise InputError("expected TRUE or FALSE", source=source, line=number, column=str(_first_column(leaf)))
    return leaf[0].upper() == "TRUE"


def read_rapid(path: str | PathLike[str]) -> ControllerProgram:
    """Read a RAPID module.

    Raises
    ------
    InputError
        Naming the file, line and column (the character, 1-based): a malformed declaration, a
        quaternion that is not a unit one, a move to an undeclared target or with an undeclared tool
        or work object, a tool not held by the robot or a work object held by it, an unsupported
        move instruction, or a target moved to with two different tools or work objects.
    """
    file = Path(path)
    source = str(file)
    lines = read_lines(file, "the program")
    program = ControllerProgram(language="RAPID", files={"mod": lines}, paths={"mod": source})
    declared, tools, wobjs = _declarations(lines, source)
    targets: dict[str, Target] = {}
    for index, line in enumerate(lines):
        code = _code(line)
        if _STRUCTURE.match(code) or _DECLARATION.match(code):
            continue
        move = _MOVE.match(code)
        if not move:
            refused = _REFUSED.match(code)
            if refused:
                raise InputError(
                    f"'{refused.group(1)}' is not supported: it moves the robot in a way this reader cannot follow (docs/controllers.md)",
                    source=source, line=index + 1, column=str(refused.start(1) + 1),
                )
            program.unsupported += 1
            continue
        program.motions += 1
        _add_move_targets(move, code, index + 1, source, (declared, tools, wobjs), targets, program)
    program.targets = list(targets.values())
    set_rotations(program.targets, quaternion_rotation)
    return program


def _declarations(lines: list[str], source: str) -> tuple[dict[str, tuple], dict[str, np.ndarray], dict[str, np.ndarray]]:
    """The module's target declarations, and its tools and work objects as poses (tool0 and wobj0 included)."""
    declared: dict[str, tuple] = {}
    tools = {"TOOL0": IDENTITY}
    wobjs = {"WOBJ0": IDENTITY}
    for index, line in enumerate(lines):
        code = _code(line)
        match = _DECLARATION.match(code)
        if not match:
            continue
        kind, name = match.group(2).lower(), match.group(3)
        node, end = _literal(code, match.end(), source, index + 1)
        if not code[end:].strip().startswith(";"):
            raise InputError("expected ';' after the declaration (one declaration per line)", source=source, line=index + 1, column=str(end + 1))
        if kind == "tooldata":
            if not isinstance(node, list) or len(node) < 2:
                raise InputError("expected tooldata as [robhold, tframe, tload]", source=source, line=index + 1, column=str(match.end() + 1))
            if not _flag(node[0], source, index + 1):
                raise InputError(f"tool {name} is a stationary tool (robhold FALSE), which is not supported", source=source, line=index + 1, column=str(_first_column(node[0])))
            tools[name.upper()] = _pose(node[1], f"tool {name}'s tframe", source, index + 1)
        elif kind == "wobjdata":
            if not isinstance(node, list) or len(node) != 5:
                raise InputError("expected wobjdata as [robhold, ufprog, ufmec, uframe, oframe]", source=source, line=index + 1, column=str(match.end() + 1))
            if _flag(node[0], source, index + 1) or not _flag(node[1], source, index + 1):
                raise InputError(
                    f"work object {name} is held by the robot or moved by a mechanical unit, which is not supported",
                    source=source, line=index + 1, column=str(_first_column(node[0])),
                )
            wobjs[name.upper()] = compose(_pose(node[3], f"{name}'s uframe", source, index + 1), _pose(node[4], f"{name}'s oframe", source, index + 1))
        else:
            declared[name.upper()] = (kind, node, index, match.start(3) + 1, name)
    return declared, tools, wobjs


def _add_move_targets(move: re.Match, code: str, number: int, source: str, frames: tuple, targets: dict[str, Target],
                      program: ControllerProgram) -> None:
    """Check one move instruction and add the targets it moves to (once each, with the tool and work object of the move)."""
    declared, tools, wobjs = frames
    verb = move.group(1)
    positional, options = _arguments(move.group(2))
    wanted = {"movec": 2}.get(verb.lower(), 1)
    if len(positional) < wanted + 3:
        raise InputError(f"{verb} needs {'a circle point, an end point' if wanted == 2 else 'a target'}, a speed, a zone and a tool", source=source, line=number)
    tool_name = positional[wanted + 2]
    if tool_name.upper() not in tools:
        raise InputError(f"tool '{tool_name}' is not declared in this module (or tool0)", source=source, line=number, column=str(code.find(tool_name) + 1))
    wobj_name = options.get("WOBJ", "wobj0")
    if wobj_name.upper() not in wobjs:
        raise InputError(
            f"work object '{wobj_name}' is not declared in this module: the target's frame is unknown (declare the wobjdata here)",
            source=source, line=number, column=str(code.find(wobj_name) + 1),
        )
    for name_text in positional[:wanted]:
        column = code.find(name_text) + 1
        if name_text.startswith("[") or "(" in name_text:
            raise InputError("an inline target or a function of one (Offs, RelTool) is not supported: declare the target and move to its name",
                             source=source, line=number, column=str(column))
        key = name_text.upper()
        kind = declared.get(key, ("",))[0]
        if verb.lower() == "moveabsj" and kind != "jointtarget" or verb.lower() != "moveabsj" and kind != "robtarget":
            wanted_kind = "jointtarget" if verb.lower() == "moveabsj" else "robtarget"
            raise InputError(f"'{name_text}' is not a {wanted_kind} declared in this module", source=source, line=number, column=str(column))
        tool, base = tools[tool_name.upper()], wobjs[wobj_name.upper()] if kind == "robtarget" else IDENTITY
        if key in targets:
            seen = targets[key]
            if not (same_frame(seen.tool, tool) and same_frame(seen.base, base)):
                raise InputError(
                    f"target {name_text} is moved to with tool {tool_name} and work object {wobj_name}, not the {seen.tool_name} and "
                    f"{seen.base_name} of its first move: one declaration cannot carry two compensated poses; declare a target per frame",
                    source=source, line=number, column=str(column),
                )
            continue
        targets[key] = _target(declared[key], source, tool, base, tool_name, wobj_name, program)


def _arguments(text: str) -> tuple[list[str], dict[str, str]]:
    """Positional arguments (top-level, ``\\`` options cut off) and the ``\\Name:=value`` options (names upper case)."""
    parts, depth, current = [], 0, ""
    for char in text:
        if char in "[(":
            depth += 1
        elif char in "])":
            depth -= 1
        if char == "," and depth == 0:
            parts.append(current)
            current = ""
        else:
            current += char
    parts.append(current)
    positional, options = [], {}
    for part in parts:
        pieces = part.split("\\")
        if pieces[0].strip():
            positional.append(pieces[0].strip())
        for option in pieces[1:]:
            name, _, value = option.partition(":=")
            options[name.strip().upper()] = value.strip()
    return positional, options


def _target(entry, source: str, tool, base, tool_name: str, wobj_name: str, program: ControllerProgram) -> Target:
    kind, node, index, column, name = entry
    number = index + 1
    fields: dict[str, tuple[int, int, str]] = {}
    if kind == "robtarget":
        if not isinstance(node, list) or len(node) != 4:
            raise InputError("expected robtarget as [[x,y,z],[q1,q2,q3,q4],[cf1,cf4,cf6,cfx],[eax_a,…,eax_f]]", source=source, line=number, column=str(column))
        quaternion, origin = _pose(node[:2], f"target {name}", source, number, fields=fields)
        conf = _numbers(node[2], 4, "confdata [cf1, cf4, cf6, cfx]", source, number)
        values = {}
        for key, leaf in zip(("cf1", "cf4", "cf6", "cfx"), conf):
            if not re.fullmatch(r"[-+]?\d+", leaf[0]):
                raise InputError(f"expected a whole number for {key}, got '{leaf[0]}'", source=source, line=number, column=str(leaf[1] + 1))
            values[key] = int(leaf[0])
            fields[key] = (leaf[1], leaf[2], leaf[0])
        program.spans[name.upper()] = ("mod", index, fields)
        return Target(
            name=name, cartesian=True, rotation=np.eye(3), origin=origin, orientation=quaternion, q=np.full(6, np.nan), configuration=values,
            source=source, line=number, column=column, tool=tool, base=base, tool_name=tool_name, base_name=wobj_name,
        )
    if not isinstance(node, list) or len(node) != 2:
        raise InputError("expected jointtarget as [[rax_1,…,rax_6],[eax_a,…,eax_f]]", source=source, line=number, column=str(column))
    axes = _numbers(node[0], 6, "robax [rax_1, …, rax_6] in deg", source, number)
    for j, leaf in enumerate(axes):
        fields[f"rax_{j + 1}"] = (leaf[1], leaf[2], leaf[0])
    program.spans[name.upper()] = ("mod", index, fields)
    return Target(
        name=name, cartesian=False, rotation=np.zeros((3, 3)), origin=np.zeros(3), q=np.array([float(leaf[0]) for leaf in axes]) * DEG,
        configuration={}, source=source, line=number, column=column, tool=tool, base=IDENTITY, tool_name=tool_name, base_name="wobj0",
    )


def _format(decimals: int):
    def write(key: str, value) -> str:
        if key.startswith("cf"):
            return str(int(value))
        if key.startswith("q"):
            # Quaternion components are dimensionless: two more decimals than mm keep the orientation to 1e-6 rad.
            return f"{value:.{decimals + 2}f}"
        return f"{value:.{decimals}f}"

    return write


def write_rapid(program: ControllerProgram, rewrites: dict, decimals: int) -> dict[str, str]:
    """The module's text with ``rewrites`` (:class:`~bayescal.controllers.program.Rewrite` by target name) applied."""
    return program.rewritten({name.upper(): rewrite for name, rewrite in rewrites.items()}, COMMENT, _format(decimals))
