"""Tests for bayescal/jsonfiles.py: a result's JSON read back and checked against its class's schema."""

from __future__ import annotations

import json

import pytest

from bayescal.critique.results import CRITIQUE_JSON
from bayescal.errors import InputError
from bayescal.jsonfiles import JsonSchema, read_json_object

SCHEMA = JsonSchema({"verdict": str, "count": int}, "bayescal thing --json", foreign="parameters", values={"verdict": ("yes", "no")})


def test_a_file_is_read_and_passes_its_schema(tmp_path):
    path = tmp_path / "thing.json"
    path.write_text(json.dumps({"verdict": "yes", "count": 3}))
    data = read_json_object(path, "the --thing file")
    SCHEMA.check_kind(data, str(path), "--thing")
    SCHEMA.check_keys(data, str(path))
    assert data == {"verdict": "yes", "count": 3}


@pytest.mark.parametrize(
    "text, message",
    [
        ("{", "not valid JSON"),
        ("[1]", "expected a JSON object (the output of bayescal thing --json), got a list"),
        ('{"parameters": {}}', "the JSON has the key 'parameters' of another command's output; --thing expects the output of bayescal thing --json"),
        ('{"verdict": "yes"}', "expected the key 'count' of the output of bayescal thing --json, found no such key"),
        ('{"verdict": "yes", "count": true}', "found a bool"),
        ('{"verdict": "maybe", "count": 1}', "expected a verdict yes or no, got 'maybe'"),
    ],
)
def test_a_wrong_file_is_one_error_naming_the_file_and_the_writer(tmp_path, text, message):
    path = tmp_path / "thing.json"
    path.write_text(text)
    with pytest.raises(InputError, match="thing.json") as error:
        data = read_json_object(path, "the --thing file")
        SCHEMA.check_kind(data, str(path), "--thing")
        SCHEMA.check_keys(data, str(path))
    assert message in str(error.value)


def test_a_file_not_in_utf_8_is_refused(tmp_path):
    path = tmp_path / "latin.json"
    path.write_bytes('{"verdict": "é"}'.encode("latin-1"))
    with pytest.raises(InputError, match="not a UTF-8 text file"):
        read_json_object(path, "the --thing file")


def test_the_critique_schema_takes_what_a_critique_writes():
    payload = {"verdict": "adequate", "causes": [], "evidence": {}, "gain": {}}
    CRITIQUE_JSON.check_keys(payload, "critique.json")
    with pytest.raises(InputError, match="expected a verdict adequate or misfit"):
        CRITIQUE_JSON.check_keys(payload | {"verdict": "fine"}, "critique.json")


def test_a_findings_record_keeps_a_null_key_apart_from_a_missing_one_and_the_file_s_order():
    from dataclasses import dataclass, field

    from bayescal.jsonfiles import findings_fields, findings_json

    @dataclass(frozen=True)
    class Record:
        verdict: str
        note: str | None = None
        keys: tuple[str, ...] = ()
        extra: dict = field(default_factory=dict)

    data = {"newer": [1, 2], "note": None, "verdict": "yes"}
    record = Record(**findings_fields(Record, data))
    assert (record.verdict, record.note, record.extra) == ("yes", None, {"newer": [1, 2]})
    assert list(findings_json(record).items()) == list(data.items())
    assert findings_json(Record(**findings_fields(Record, {"verdict": "no"}))) == {"verdict": "no"}
