"""Hostile cells, design options and registrations: each refused in one line naming the key or the option, exit status 2,
every input byte-identical and nothing written.

The cells' loads are held to the rules the options are (:mod:`bayescal.cell.plausible`); a registration is checked
against the cell it is applied to (its robot, its joints, its home pose) and its covariances.
"""

from __future__ import annotations

import copy
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cli import main
from bayescal.twin.sweeps import random_placement, simulate_sweeps

DATA = Path(__file__).resolve().parents[2] / "data"
HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]


def _digest(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` and the hash of its bytes."""
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


def _cell_text(name: str, old: str = "", new: str = "") -> str:
    text = (DATA / name).read_text().replace('urdf = "', f'urdf = "{DATA}/').replace('reference_csv = "', f'reference_csv = "{DATA}/')
    assert old in text
    return text.replace(old, new)


@pytest.fixture(scope="module")
def files(tmp_path_factory, twin_campaign, cell):
    """Cells with implausible loads, a campaign, and a registration `bayescal axes -o` wrote, with hostile edits of it."""
    folder = tmp_path_factory.mktemp("hostile_cells")
    write_campaign(twin_campaign([], seed=4, repeats=1), folder / "campaign.csv")
    (folder / "points.csv").write_bytes((DATA / "table1_geometry.csv").read_bytes())
    (folder / "plan.csv").write_bytes((DATA / "table3_plan.csv").read_bytes())
    (folder / "cell.toml").write_text(_cell_text("kr270.toml"))
    cells = {
        "design_28t": ("kr270.toml", "mass_kg = [250.0, 280.0]", "mass_kg = [25000, 28000]"),
        "design_reversed": ("kr270.toml", "mass_kg = [250.0, 280.0]", "mass_kg = [280.0, 250.0]"),
        "load_265t": ("kr270.toml", "mass_kg = 265.0", "mass_kg = 265000.0"),
        "any_no_force": ("kr270_any_load.toml", "force_max_N = 2750.0\ncouple_max_Nm = 500.0", "force_max_N = 1e-9\ncouple_max_Nm = 0"),
        "any_couple_in_Nmm": ("kr270_any_load.toml", "couple_max_Nm = 500.0", "couple_max_Nm = 500000.0"),
    }
    for name, edit in cells.items():
        (folder / f"{name}.toml").write_text(_cell_text(*edit))

    rng = np.random.default_rng(7)
    simulate_sweeps(cell, random_placement(rng), rng, home_deg=HOME).to_csv(folder / "sweeps.csv", index=False)
    assert main(["axes", str(folder / "sweeps.csv"), "--config", str(folder / "cell.toml"), "-o", str(folder / "reg.json")]) == 0
    registration = json.loads((folder / "reg.json").read_text())
    assert registration["robot"] == "kr270" and registration["home_deg"] == HOME

    def variant(name, change):
        edited = copy.deepcopy(registration)
        change(edited)
        (folder / f"{name}.json").write_text(json.dumps(edited, indent=2))

    variant("reg_home7", lambda r: r["home_deg"].append(0.0))
    variant("reg_no_home", lambda r: r.pop("home_deg"))
    variant("reg_home_beyond", lambda r: r["home_deg"].__setitem__(1, -190.0))
    variant("reg_arm7", lambda r: r.__setitem__("robot", "arm7"))
    for frame in ("base", "paper"):
        variant(f"reg_negative_{frame}", lambda r, frame=frame: r["frames"][frame].__setitem__("rotation_cov_mrad2", (-np.eye(3)).tolist()))
    variant("reg_asymmetric", lambda r: r["frames"]["base"]["translation_cov_mm2"][0].__setitem__(1, 5.0))
    return folder


# Each case: the argv ({f} is the inputs' folder) and words its one line must hold (exit status 2).
CASES = {
    "plan: a 28 t design load in the cell": (
        "plan --config {f}/design_28t.toml --model linear -o {f}/p.csv",
        "column 'design.mass_kg': a load of 28000 kg is more than the 540 kg the arm can plausibly carry"),
    "plan: a reversed design range in the cell": (
        "plan --config {f}/design_reversed.toml --model linear -o {f}/p.csv", "design.mass_kg': expected the lighter mass first"),
    "plan: a 265 t calibration load in the cell": ("plan --config {f}/load_265t.toml --model linear -o {f}/p.csv", "load.mass_kg"),
    "plan: an end-effector of 1e-9 N and no couple": (
        "plan --config {f}/any_no_force.toml --model linear -o {f}/p.csv", "column 'load.force_max_N': a largest force of 1e-09 N is below 26 N"),
    "plan: couples in N mm": ("plan --config {f}/any_couple_in_Nmm.toml --model linear -o {f}/p.csv", "is it in N·mm instead of N·m?"),
    "plan: a reversed --mass-kg": ("plan --config {f}/cell.toml --mass-kg 280 250 -o {f}/p.csv", "--mass-kg: expected the lighter mass first"),
    "plan: --per-angle 1000000": (
        "plan --config {f}/cell.toml --model linear --per-angle 1000000 -o {f}/p.csv", "--per-angle: expected at most 20 configurations"),
    "plan: --per-angle 1000000 to discriminate": (
        "plan --config {f}/cell.toml --criterion discriminate --between backlash,nonlinear_stiffness --campaign {f}/campaign.csv "
        "--per-angle 1000000 -o {f}/p.csv", "--per-angle: expected 1 to 32 configurations per q2 angle"),
    "simulate: a 28 t design load in the cell": ("simulate --plan {f}/plan.csv --config {f}/design_28t.toml -o {f}/p.csv", "design.mass_kg"),
    "study: --max-per-angle 100000": (
        "study q2-angles --config {f}/cell.toml --max-per-angle 100000 -o {f}/s.csv", "--max-per-angle: expected at most 20"),
    "study: a 28 t design load in the cell": ("study q2-angles --config {f}/design_28t.toml -o {f}/s.csv", "design.mass_kg"),
    "calibrate: a registration of 7 joints": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_home7.json --posterior {f}/c.nc",
        "column 'home_deg': the home pose has 7 joint angles, but the robot of"),
    "calibrate: a registration without a home pose": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_no_home.json --posterior {f}/c.nc", "expected home_deg"),
    "calibrate: a registration's home beyond the joint limits": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_home_beyond.json --posterior {f}/c.nc",
        "the home pose's joint A2 at -190.000 deg is outside its limits"),
    "calibrate: a registration of another robot": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_arm7.json --posterior {f}/c.nc",
        "made for the robot 'arm7', but the robot of"),
    "calibrate: a negative rotation covariance": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_negative_base.json --posterior {f}/c.nc",
        "column 'frames.base.rotation_cov_mrad2': a negative variance (eigenvalue -1 mrad²)"),
    "calibrate: an asymmetric translation covariance": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_asymmetric.json --posterior {f}/c.nc",
        "frames.base.translation_cov_mm2': a matrix that is not symmetric"),
    "critique: a registration of 7 joints": (
        "critique {f}/campaign.csv --config {f}/cell.toml --registration {f}/reg_home7.json", "7 joint angles"),
    "critique geometry: a negative rotation covariance": (
        "critique --geometry {f}/points.csv --registration {f}/reg_negative_paper.json", "frames.paper.rotation_cov_mrad2"),
    "geometry: a negative rotation covariance": (
        "geometry {f}/points.csv --registration {f}/reg_negative_paper.json --posterior {f}/c.nc", "a negative variance"),
    "geometry: a registration without a home pose": (
        "geometry {f}/points.csv --registration {f}/reg_no_home.json --posterior {f}/c.nc", "expected home_deg"),
    "report: a registration of another robot": (
        "report --registration {f}/reg_arm7.json --config {f}/cell.toml -o {f}/out", "made for the robot 'arm7'"),
    "report: a negative rotation covariance": ("report --registration {f}/reg_negative_base.json -o {f}/out", "a negative variance"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_case_exits_with_one_line_and_leaves_inputs_untouched(files, capsys, case):
    template, words = CASES[case]
    before = _digest(files)
    code = main(template.format(f=files).split())
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and words in lines[0], lines
    assert "Traceback" not in lines[0]
    assert _digest(files) == before
    assert not [name for name in ("p.csv", "s.csv", "c.nc", "out") if (files / name).exists()]
    assert not list(files.rglob("*.tmp*"))


def test_the_study_refuses_its_largest_plan_before_drawing_candidates(files, capsys, monkeypatch):
    def no_draw(*args, **kwargs):
        raise AssertionError("candidates drawn before the request was checked")

    monkeypatch.setattr("bayescal.design.optimise.PlanDesigner.candidates", no_draw)
    code = main(["study", "q2-angles", "--config", str(files / "cell.toml"), "--max-per-angle", "100000"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "--max-per-angle" in lines[0], lines


def test_a_registration_of_the_cell_passes_its_checks(files, capsys, tmp_path):
    code = main(["report", "--registration", str(files / "reg.json"), "--config", str(files / "cell.toml"), "-o", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
