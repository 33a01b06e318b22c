"""The lists the documentation restates are the lists the code has: each table or list below fails its test
when an entry is added, removed, renamed or reordered in the code and not in the page (or the reverse).

The help texts are built from the same registries (``simulate --effect``, ``critique``'s catalogues); a list
the command line must know before importing the registry (``plan --criterion``'s choices) is checked here.
"""

import argparse
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _table(page: str, header: str) -> list[list[str]]:
    """The rows of the Markdown table of ``docs/<page>`` whose header line is ``header``, cells stripped."""
    lines = (ROOT / "docs" / page).read_text(encoding="utf-8").splitlines()
    assert lines.count(header) == 1, f"docs/{page} has {lines.count(header)} tables headed {header!r}"
    rows = []
    for line in lines[lines.index(header) + 2 :]:
        if not line.startswith("|"):
            break
        rows.append(_cells(line))
    return rows


def _cells(line: str) -> list[str]:
    """A table row's cells: split at each ``|`` outside code spans and not escaped."""
    cells, cell, code = [], "", False
    for i, char in enumerate(line.strip()[1:-1]):
        if char == "|" and not code and (i == 0 or line.strip()[i] != "\\"):
            cells.append(cell.strip())
            cell = ""
            continue
        code ^= char == "`"
        cell += char
    return cells + [cell.strip()]


def _names(rows: list[list[str]]) -> list[str]:
    return [row[0].strip("`") for row in rows]


def test_the_twins_effects_table_is_the_registry():
    from bayescal.twin.effects import EFFECTS

    rows = _table("twin.md", "| name | model | magnitude (default) | source |")
    assert _names(rows) == list(EFFECTS)
    documented = {row[0].strip("`"): float(re.search(r"\(([\d.]+)\)$", row[2]).group(1)) for row in rows}
    assert documented == {name: effect.default for name, effect in EFFECTS.items()}


def test_the_independent_generators_effects_table_is_the_registry():
    from bayescal.twin.independent import EFFECTS

    rows = _table("independent.md", "| name | cause | form | default | change | source of the size |")
    assert _names(rows) == list(EFFECTS)
    assert [row[1] for row in rows] == [effect.cause or "—" for effect in EFFECTS.values()]
    assert [float(re.search(r"\d+(\.\d+)?", row[3]).group()) for row in rows] == [effect.default for effect in EFFECTS.values()]


def test_the_third_generators_effects_table_is_the_registry():
    from bayescal.twin.beams.effects import EFFECTS

    assert _names(_table("generators.md", "| effect | form | default (magnitude 1) | deflection change | unloaded poses |")) == list(EFFECTS)


def test_the_critiques_catalogue_tables_are_the_catalogues():
    from bayescal.critique.extensions import CATALOGUE
    from bayescal.critique.geometry import GEOMETRY_CATALOGUE

    assert _names(_table("critique.md", "| name | columns added | parameters |")) == ["base", *CATALOGUE]
    assert _names(_table("critique.md", "| candidate | what it models | parameters (unit) |")) == list(GEOMETRY_CATALOGUE)


def test_the_probes_the_critique_page_lists_are_the_covariates():
    from bayescal.critique.extensions import PROBES

    text = (ROOT / "docs" / "critique.md").read_text(encoding="utf-8")
    listed = re.search(r"The probes are not physics: for each covariate \(([^)]*)\)", text).group(1)
    assert len(listed.split(";")) == len(PROBES)


def test_the_compensated_files_columns_are_the_writers():
    from bayescal.compensation.program import compensated_columns

    text = (ROOT / "docs" / "compensation.md").read_text(encoding="utf-8")
    output = re.search(r"\*\*Output\*\*: the program's columns, then (.*?)\. The new numbers", text, re.S).group(1)
    named = re.findall(r"`([^`]+)`", output)
    two_joints = compensated_columns(SimpleNamespace(position_units=("deg", "deg")))
    assert named[0] == "q1_cmd_deg … qn_cmd_deg" and two_joints[:2] == ("q1_cmd_deg", "q2_cmd_deg")
    # `ok` is a value of the flag column, named in its description
    assert [name for name in named[1:] if name != "ok"] == list(two_joints[2:])


def test_the_plan_criteria_the_command_offers_are_the_designs():
    from bayescal.cli import build_parser
    from bayescal.design.criteria import CRITERIA

    plan = next(
        action.choices["plan"] for action in build_parser()._actions if isinstance(action, argparse._SubParsersAction)
    )
    criterion = next(action for action in plan._actions if "--criterion" in action.option_strings)
    assert tuple(criterion.choices) == (*CRITERIA, "discriminate")


@pytest.mark.parametrize("command", ["simulate", "critique"])
def test_the_help_texts_list_the_registries(command, capsys):
    from bayescal.cli import main
    from bayescal.critique.extensions import CATALOGUE
    from bayescal.twin.effects import EFFECTS

    assert main([command, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    if command == "simulate":
        assert all(f"{name}: {' '.join(effect.summary.split())}" in text for name, effect in EFFECTS.items())
    else:
        assert f"({', '.join(CATALOGUE)};" in text


def test_the_sweep_critiques_candidates_table_is_the_catalogue():
    from bayescal.critique.sweeps import CANDIDATES, UNITS

    rows = _table("registration.md", "| candidate | what | parameters | size reported in |")
    assert _names(rows) == list(CANDIDATES)
    assert [int(row[2]) for row in rows] == list(CANDIDATES.values())
    # the page writes μm where the JSON's unit is ASCII
    assert [row[3] for row in rows] == [UNITS[name].replace("um", "μm") for name in CANDIDATES]
