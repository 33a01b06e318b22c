"""The cell file as text: UTF-8 TOML whose tables and keys the schema knows, read with errors that name the line.

:func:`read_cell_file` decodes and parses a cell file and refuses a table or key
the schema does not know; the :class:`CellFileReader` it returns gives typed
access to the values, each error naming the file, the line and the key.
:func:`bayescal.cell.config.load_cell` and :mod:`bayescal.cell.joints` read
the cell through it.
"""

from __future__ import annotations

import codecs
import difflib
import math
import tomllib
from collections.abc import Mapping
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from bayescal.errors import InputError
from bayescal.output import record_read
from bayescal.robot.kinds import LAWS

__all__ = ["CellFileReader", "COMPENSATOR_KEYS", "SCHEMA", "read_cell_file"]

COMPENSATOR_KEYS = frozenset({"joint", "kind", "L_mm", "a_x_mm", "a_y_mm", "phi_deg"})
"""The ``[compensator]`` keys of every law; each law adds its own (:data:`bayescal.robot.kinds.LAWS`)."""

SCHEMA: dict[str, frozenset[str] | None] = {
    "robot": frozenset({"urdf", "flange", "payload_kg", "joints", "locked_deg", "locked_mm", "reference_csv", "coupled"}),
    "robot.coupled": None,
    "joints": frozenset({"k_urad_per_Nm", "k_um_per_N", "k_log_sd"}),
    "compensator": COMPENSATOR_KEYS | frozenset(p.key for law in LAWS.values() for p in law.PARAMETERS + law.CONSTANTS),
    "tool": frozenset({"load_point_mm", "markers_mm", "tcp_mm", "mass_kg", "com_mm"}),
    "tool.markers_mm": None,
    "tracker": frozenset({"position_mm", "U0_um", "U1_um_per_m", "factor"}),
    "load": frozenset({"mass_kg", "gravity_m_per_s2", "directions", "force_max_N", "couple_max_Nm"}),
    "test_pose": frozenset({"q_deg", "q_mm", "wrench_N_Nm", "point_mm"}),
    "design": frozenset({"mass_kg", "acceptance_deg", "floor_z_mm", "hanging_clearance_mm"}),
    # A cell of measured points (``bayescal kinematics``): markers on named links, the base in the tracker frame.
    "markers": None,
    "base": frozenset({"position_mm", "rpy_deg", "gravity_m_per_s2"}),
    "frames": frozenset({"free"}),
    "priors": frozenset({
        "base_sd_mm", "base_sd_deg", "frame_sd_mm", "frame_sd_deg", "marker_sd_mm", "offset_sd_deg", "length_sd_mm",
        "twist_sd_deg", "joint_compliance_sd_urad_per_Nm", "transversal_compliance_sd_urad_per_Nm", "mass_sd_fraction",
        "com_sd_mm",
    }),
}
"""The tables of a cell file and their keys (``None``: any key, e.g. marker names).

Any other table or key is an error: a misspelt optional key (``factr``) would
otherwise be ignored silently and its default used."""


def read_cell_file(path: str | PathLike[str]) -> CellFileReader:
    """A reader of the cell file at ``path``, its tables and keys checked against :data:`SCHEMA`.

    Raises
    ------
    InputError
        A folder or a missing file, bytes that are not UTF-8, invalid TOML, or an
        unknown table or key (naming the closest known one).
    """
    source = str(path)
    file = Path(path)
    if file.is_dir():
        raise InputError("is a folder; expected a cell TOML file", source=source)
    if not file.is_file():
        raise InputError("cell file not found", source=source)
    record_read(file, "the cell file")
    try:
        raw = file.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read the cell file ({exc.strerror or type(exc).__name__})", source=source) from None
    # A byte-order mark is accepted here as by the CSV readers (editors on Windows add one).
    raw = raw.removeprefix(codecs.BOM_UTF8)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"byte 0x{raw[exc.start]:02x} is not UTF-8 text (a Latin-1 or Windows-1252 character?): save the file as UTF-8",
            source=source,
            line=raw[: exc.start].count(b"\n") + 1,
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not a valid TOML file ({exc})", source=source) from None
    reader = CellFileReader(data, text, source)
    reader.check_keys()
    return reader


def is_points_cell(path: str | PathLike[str]) -> bool:
    """Whether the cell file at ``path`` describes measured points (it has a ``[markers]`` table): a cell of
    :mod:`bayescal.kinematics`, told apart here so that a command learns which cell it reads without importing that
    calibration."""
    try:
        return "markers" in read_cell_file(path).data
    except InputError:
        return False


class CellFileReader:
    """Typed access to the TOML tables with errors naming the file, the line and the key."""

    def __init__(self, data: Mapping[str, Any], text: str, source: str) -> None:
        self.data = data
        self.lines = text.splitlines()
        self.source = source

    def line(self, table: str, key: str | None = None) -> int | None:
        current = ""
        for number, raw in enumerate(self.lines, start=1):
            stripped = raw.strip()
            if stripped.startswith("["):
                current = stripped.strip("[]").strip()
                if key is None and current == table:
                    return number
            elif key is not None and current == table and stripped.split("=")[0].strip() == key:
                return number
        return None

    def fail(self, what: str, table: str, key: str | None = None):
        column = table if key is None else f"{table}.{key}"
        raise InputError(what, source=self.source, line=self.line(table, key), column=column)

    def table(self, name: str, *, required: bool = True) -> Mapping[str, Any] | None:
        node: Any = self.data
        for part in name.split("."):
            if not isinstance(node, Mapping) or part not in node:
                if required:
                    raise InputError(f"missing table [{name}]", source=self.source)
                return None
            node = node[part]
        if not isinstance(node, Mapping):
            self.fail(f"expected a table [{name}]", name)
        return node

    def number(
        self,
        table: str,
        key: str,
        *,
        unit: str,
        positive: bool = False,
        non_negative: bool = False,
        default: float | None = None,
    ) -> float:
        values = self.table(table)
        if key not in values:
            if default is not None:
                return default
            self.fail(f"missing key '{key}' (a number in {unit})", table)
        value = values[key]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(f"expected a number in {unit}, got {value!r}", table, key)
        if positive and value <= 0:
            self.fail(f"expected a positive number in {unit}, got {value!r}", table, key)
        if non_negative and value < 0:
            self.fail(f"expected a number >= 0 in {unit}, got {value!r}", table, key)
        return float(value)

    def vector(self, table: str, key: str, size: int, *, unit: str) -> np.ndarray:
        values = self.table(table)
        if key not in values:
            self.fail(f"missing key '{key}' (a list of {size} numbers in {unit})", table)
        return self.vector_value(values[key], size, unit, table, key)

    def vector_value(self, value: Any, size: int, unit: str, table: str, key: str) -> np.ndarray:
        ok = isinstance(value, list) and len(value) == size
        ok = ok and all(not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(x) for x in value)
        if not ok:
            self.fail(f"expected a list of {size} numbers in {unit}, got {value!r}", table, key)
        return np.array(value, dtype=float)

    def check_keys(self) -> None:
        """Reject tables and keys the schema does not know, naming the closest known one."""
        tables = sorted(name for name in SCHEMA if "." not in name)
        for name, node in self.data.items():
            if name in SCHEMA and isinstance(node, Mapping):
                self._check_table(name, node)
                continue
            if name in SCHEMA:
                raise InputError(
                    f"expected the table [{name}], got the value {node!r}", source=self.source, line=self.line("", name), column=name
                )
            close = difflib.get_close_matches(name, tables, n=1, cutoff=0.6)
            hint = f"did you mean [{close[0]}]? " if close else ""
            kind = f"table [{name}]" if isinstance(node, Mapping) else f"key '{name}' outside any table"
            raise InputError(
                f"unknown {kind}; {hint}known tables: {', '.join(f'[{table}]' for table in tables)}",
                source=self.source,
                line=self.line(name) if isinstance(node, Mapping) else self.line("", name),
                column=name,
            )

    def _check_table(self, table: str, node: Mapping[str, Any]) -> None:
        known = SCHEMA[table]
        if known is None:
            return
        for key, value in node.items():
            if key not in known:
                close = difflib.get_close_matches(key, sorted(known), n=1, cutoff=0.6)
                hint = f"did you mean '{close[0]}'? " if close else ""
                self.fail(f"unknown key '{key}' in [{table}]; {hint}known keys: {', '.join(sorted(known))}", table, key)
            if isinstance(value, Mapping) and f"{table}.{key}" in SCHEMA:
                self._check_table(f"{table}.{key}", value)

    def text(self, table: str, key: str, default: str | None = None) -> str:
        values = self.table(table)
        value = values.get(key, default)
        if not isinstance(value, str) or not value:
            self.fail(f"expected a non-empty text, got {value!r}", table, key)
        return value
