"""Tests of ``bayescal study``."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

import bayescal.cli as cli

CONFIG = str(Path(__file__).resolve().parents[2] / "data" / "kr270.toml")


@pytest.fixture
def main(monkeypatch):
    # only this subcommand: the test does not depend on the others being importable
    monkeypatch.setattr(cli, "COMMANDS", ("study",))
    return cli.main


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--max-angles", "2", "argument --max-angles: expected a whole number >= 3"),
        ("--max-per-angle", "0", "argument --max-per-angle: expected a whole number >= 1"),
        ("--repeats", "0", "argument --repeats: expected a whole number >= 1"),
        ("--max-angles", "100000", "--max-angles: expected at most 30 q2 angles"),
    ],
)
def test_bad_options_exit_2_naming_the_option(main, capsys, option, value, message):
    assert main(["study", "q2-angles", "--config", CONFIG, option, value]) == 2
    assert f"bayescal study: error: {message}" in capsys.readouterr().err


@pytest.mark.slow
def test_writes_the_table(main, tmp_path, capsys):
    out, markdown = tmp_path / "angles.csv", tmp_path / "angles.md"
    args = ["study", "q2-angles", "--config", CONFIG, "--max-angles", "4", "--max-per-angle", "1", "-o", str(out), "--markdown", str(markdown), "--json"]
    assert main(args) == 0
    payload = json.loads(capsys.readouterr().out)
    table = pd.read_csv(out)
    assert len(table) == len(payload["table"]) == 4  # (3, 4 angles) x (full, 1/10 noise)
    assert {row["target"] for row in payload["identification_cost"]} == {"Table IV", "5 %"}
    assert markdown.read_text().startswith("| angles | per_angle |")
