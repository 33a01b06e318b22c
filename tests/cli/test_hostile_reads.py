"""Outputs aimed at a file the run reads without the command line naming it: the reference table a cell points to.

``data/kr270.toml`` names ``reference_csv = "paper_reference.csv"``.  Every command that writes a file,
run on a copy of that cell's folder and told to write over its reference table, must refuse in one line
naming the option and what the file is, with exit status 2, before writing anything: the table
byte-identical, no output, no temporary file.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np
import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cli import main
from bayescal_studies.studies.compensation import random_program
from bayescal.twin.sweeps import random_placement, simulate_sweeps

DATA = Path(__file__).resolve().parents[2] / "data"
SWEEP_HOME_DEG = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]
"""Home pose of the sweeps (deg), the one ``tests/cli/test_axes.py`` sweeps from."""


def _digest(folder: Path) -> dict[str, str]:
    """Every file under ``folder``, hidden ones included, and the hash of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def work(tmp_path_factory, twin_campaign, cell, short_calibration):
    """A folder holding ``cfg/`` (a copy of the KR-270 cell with its URDF and reference table) and ``in/``, good inputs."""
    folder = tmp_path_factory.mktemp("reads")
    cfg = folder / "cfg"
    (cfg / "robots").mkdir(parents=True)
    for name in ("kr270.toml", "paper_reference.csv", "robots/kr270.urdf"):
        (cfg / name).write_bytes((DATA / name).read_bytes())
    inputs = folder / "in"
    inputs.mkdir()
    write_campaign(twin_campaign([], seed=4, repeats=1), inputs / "campaign.csv")
    (inputs / "calibration.nc").write_bytes(Path(short_calibration["calibration"]).read_bytes())
    random_program(cell, 12, np.random.default_rng(0)).table.to_csv(inputs / "program.csv", index=False)
    rng = np.random.default_rng(0)
    simulate_sweeps(cell, random_placement(rng), rng, home_deg=SWEEP_HOME_DEG).to_csv(inputs / "sweeps.csv", index=False)
    (inputs / "plan.csv").write_bytes((DATA / "table3_plan.csv").read_bytes())
    os.link(cfg / "paper_reference.csv", inputs / "hard_link.csv")
    return folder


# Each case: the argv (run in the work folder) and the option its one line names.
CASES = {
    "plan -o": ("plan --config cfg/kr270.toml --model linear -o cfg/paper_reference.csv", "--output"),
    "calibrate --posterior": ("calibrate in/campaign.csv --config cfg/kr270.toml --posterior cfg/paper_reference.csv", "--posterior"),
    "compensate -o": (
        "compensate in/program.csv --calibration in/calibration.nc --config cfg/kr270.toml -o cfg/paper_reference.csv", "-o"),
    "simulate -o": ("simulate --plan in/plan.csv --config cfg/kr270.toml -o cfg/paper_reference.csv", "-o"),
    "axes -o": ("axes in/sweeps.csv --config cfg/kr270.toml -o cfg/paper_reference.csv", "-o"),
    "study --markdown": ("study q2-angles --config cfg/kr270.toml --markdown cfg/paper_reference.csv", "--markdown"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_an_output_onto_the_reference_table_the_cell_points_to_is_refused(work, capsys, monkeypatch, case):
    argv, option = CASES[case]
    monkeypatch.chdir(work)
    before = _digest(work)
    status = main(argv.split())
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and lines == [
        f"bayescal {argv.split()[0]}: error: {option}: cfg/paper_reference.csv is the reference table the cell cfg/kr270.toml "
        "points to: writing there would destroy the input; choose another output file"
    ]
    assert _digest(work) == before


def test_a_hard_link_to_the_reference_table_is_refused_naming_the_table(work, capsys, monkeypatch):
    monkeypatch.chdir(work)
    before = _digest(work)
    status = main("plan --config cfg/kr270.toml --model linear -o in/hard_link.csv".split())
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(lines) == 1
    assert f"in/hard_link.csv is the reference table the cell cfg/kr270.toml points to ({work / 'cfg' / 'paper_reference.csv'})" in lines[0]
    assert _digest(work) == before
