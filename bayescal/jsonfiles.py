"""A result's JSON file read back: valid JSON, an object, and the keys its results class writes.

Each results class that writes a JSON states its shape once, beside its ``to_json``, as a :class:`JsonSchema`
(the keys a reader relies on, with their types, and the command that writes the file); whatever reads such a
file (``bayescal report``'s ``--plan``, ``--critique``, ``--registration``) reads it with
:func:`read_json_object` and checks it against that schema, so that a wrong file is one line naming the file,
the key and the command that writes the right one.  A file that cannot rebuild its results object is read into a
*findings* record (a frozen dataclass beside the ``to_json``): :func:`findings_fields` and :func:`findings_json`
move a file's keys into the record's fields and back, the keys it does not name kept as they came.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from os import PathLike

from bayescal.errors import InputError
from bayescal.output import record_read

__all__ = ["JsonSchema", "JsonFindings", "read_json_object", "findings_fields", "findings_json"]


def read_json_object(path: str | PathLike[str], what: str):
    """The JSON value in the file at ``path`` (``what`` names it in the record of files read), or an input error."""
    record_read(path, what)
    try:
        with open(path, encoding="utf-8") as stream:
            return json.load(stream)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg} at character {exc.colno})", source=str(path), line=exc.lineno) from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text file", source=str(path)) from None


@dataclass(frozen=True)
class JsonSchema:
    """The keys of a result's JSON a reader relies on.

    Attributes
    ----------
    keys : dict
        Key -> the type (or tuple of types) its value has; a boolean never passes for a number.
    writer : str
        The command that writes the file, named in every error.
    foreign : str
        A key only another kind of result's JSON has, refused ("" for none).
    values : dict
        Key -> the values it may take, for the keys that take few (a verdict).
    """

    keys: dict[str, type | tuple[type, ...]]
    writer: str
    foreign: str = ""
    values: dict[str, tuple] = field(default_factory=dict)

    def check_kind(self, data, source: str, option: str) -> None:
        """Refuse ``data`` unless it is an object without the other kind's key; ``option`` names what expected it."""
        if not isinstance(data, dict):
            raise InputError(f"expected a JSON object (the output of {self.writer}), got a {type(data).__name__}", source=source)
        if self.foreign and self.foreign in data:
            raise InputError(f"the JSON has the key '{self.foreign}' of another command's output; {option} expects the output of "
                             f"{self.writer}", source=source)

    def check_keys(self, data: dict, source: str) -> None:
        """Refuse ``data`` when a key is missing, of another type, or takes a value it cannot."""
        for key, kind in self.keys.items():
            if key not in data or not isinstance(data[key], kind) or isinstance(data[key], bool):
                found = "no such key" if key not in data else f"a {type(data[key]).__name__}"
                raise InputError(f"expected the key '{key}' of the output of {self.writer}, found {found}", source=source, column=key)
        for key, allowed in self.values.items():
            if data[key] not in allowed:
                raise InputError(f"expected a {key} {' or '.join(allowed)}, got {data[key]!r}", source=source, column=key)


def findings_fields(record_class: type, data: dict) -> dict:
    """The keyword arguments of the findings dataclass ``record_class`` for the JSON object ``data``.

    Each key named by a field goes to that field; the others go to ``extra`` (in the file's order), and ``keys``
    keeps every key in the file's order, so that a key the file holds as null stays apart from one it lacks.
    """
    named = {f.name for f in fields(record_class)} - {"keys", "extra"}
    return {key: value for key, value in data.items() if key in named} | {
        "keys": tuple(data), "extra": {key: value for key, value in data.items() if key not in named}}


def findings_json(record) -> dict:
    """The JSON object a findings record was read from: its file's keys in their order, each from its field or ``extra``
    (a record built without ``keys``: its fields that are not None, then ``extra``)."""
    order = record.keys or (*(f.name for f in fields(record) if f.name not in ("keys", "extra") and getattr(record, f.name) is not None),
                            *record.extra)
    return {key: record.extra[key] if key in record.extra else getattr(record, key) for key in order}


class JsonFindings:
    """What a findings record (a frozen dataclass with ``keys`` and ``extra`` fields) reads and writes: the JSON file
    a command printed, checked against the one schema of the results class that wrote it.

    A record sets ``SCHEMA`` (its :class:`JsonSchema`), ``OPTION`` (the option that names its file in errors) and
    ``NAME`` (what a JSON object handed over without a file is called in errors).
    """

    SCHEMA: JsonSchema
    OPTION: str
    NAME: str

    def to_json(self) -> dict:
        return findings_json(self)

    @classmethod
    def from_json(cls, data, source: str | None = None, option: str | None = None):
        """The findings in ``data``, checked against ``SCHEMA``; ``source`` and ``option`` name it in errors."""
        source, option = source or cls.NAME, option or cls.OPTION
        cls.SCHEMA.check_kind(data, source, option)
        cls.SCHEMA.check_keys(data, source)
        return cls(**findings_fields(cls, data))

    @classmethod
    def load(cls, path: str | PathLike[str], option: str | None = None):
        """The findings in the JSON file at ``path`` (the output of ``SCHEMA.writer``); ``option`` names it in errors."""
        option = option or cls.OPTION
        return cls.from_json(read_json_object(path, f"the {option} file"), str(path), option)
