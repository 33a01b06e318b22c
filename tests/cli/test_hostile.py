"""Hostile inputs to every command: each gives its exit status, exactly one line on stderr, and leaves every input byte-identical.

The cases are those a new user tried (outputs over inputs, unit slips, files of the wrong kind,
unsupported options, interrupts); the output-path property test throws random output paths at
every command.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cli import main

DATA = Path(__file__).resolve().parents[2] / "data"
CONFIG = DATA / "kr270.toml"
URDF = DATA / "robots" / "kr270.urdf"
FIXTURES = Path(__file__).resolve().parents[1] / "reports" / "data"
WRENCH = ["fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm"]


def _digest(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (links followed) and the hash of its bytes."""
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def files(tmp_path_factory, twin_campaign, cell, short_calibration):
    """A folder of inputs, good and hostile, written once."""
    folder = tmp_path_factory.mktemp("hostile")
    good = folder / "campaign.csv"
    write_campaign(twin_campaign([], seed=4, repeats=1), good, comments=["twin, Table III"])
    frame = pd.read_csv(good, comment="#")

    def variant(name, change):
        changed = frame.copy()
        change(changed)
        changed.to_csv(folder / f"{name}.csv", index=False, float_format="%.6f")

    variant("zero_wrench", lambda f: f.__setitem__(WRENCH, 0.0))
    variant("moments_in_Nmm", lambda f: f.__setitem__(WRENCH[3:], f[WRENCH[3:]] * 1000))
    variant("wrench_flipped", lambda f: f.__setitem__(WRENCH, -f[WRENCH]))
    variant("q2_beyond", lambda f: f.__setitem__("q2_deg", f["q2_deg"] - 200))

    def swap(f):
        for axis in "xyz":
            f[f"{axis}0_mm"], f[f"{axis}1_mm"] = frame[f"{axis}1_mm"], frame[f"{axis}0_mm"]

    variant("columns_swapped", swap)
    # A campaign of a robot twice as compliant as the cell the calibration is of.
    soft = dataclasses.replace(cell, compliances=2 * cell.compliances)
    write_campaign(twin_campaign([], seed=1, repeats=1, cell_=soft), folder / "soft.csv")

    points = pd.read_csv(DATA / "table1_geometry.csv", comment="#")
    points.to_csv(folder / "points.csv", index=False)
    points.assign(q2_deg=np.deg2rad(points["q2_deg"])).to_csv(folder / "points_rad.csv", index=False)

    text = CONFIG.read_text().replace('urdf = "', f'urdf = "{DATA}/')
    (folder / "cell.toml").write_text(text)
    (folder / "cell_far_marker.toml").write_text(text.replace("M1 = [200.0, 0.0, 115.47]", "M1 = [200000.0, 0.0, 115.47]"))
    (folder / "cell_L_in_um.toml").write_text(text.replace("L_mm = 184.72", "L_mm = 184720"))
    pd.read_csv(DATA / "table3_plan.csv", comment="#").assign(q2_deg=-30.0).to_csv(folder / "one_angle_plan.csv", index=False)
    (folder / "hello.json").write_text(json.dumps({"hello": 1}))
    (folder / "plan.json").write_text((FIXTURES / "plan.json").read_text())
    critique = json.loads((FIXTURES / "critique.json").read_text())
    (folder / "critique.json").write_text(json.dumps(critique))
    (folder / "banana.json").write_text(json.dumps(critique | {"verdict": "banana"}))
    for name, path in short_calibration.items():
        if name in ("geometry", "calibration"):
            (folder / f"{name}.nc").write_bytes(Path(path).read_bytes())
    (folder / "figures").mkdir()
    os.symlink(good, folder / "figures" / "residuals.png")
    (folder / "hard").mkdir()
    os.link(good, folder / "hard" / "loo_pit.png")
    (folder / "geometry_figures").mkdir()
    os.symlink(folder / "points.csv", folder / "geometry_figures" / "geometry_residuals.png")
    os.symlink(URDF, folder / "urdf_link.csv")
    return folder


# Each case: the argv ({f} is the inputs' folder), the exit status and words its one line must hold.
CASES = {
    "critique figures over the campaign (symlink)": (
        "critique {f}/campaign.csv --config {f}/cell.toml --figures {f}/figures", 2, "would destroy the input"),
    "critique figures over the campaign (hard link)": (
        "critique {f}/campaign.csv --config {f}/cell.toml --figures {f}/hard", 2, "would destroy the input"),
    "critique figures folder is the campaign": (
        "critique {f}/campaign.csv --config {f}/cell.toml --figures {f}/campaign.csv", 2, "the campaign this command reads"),
    "critique geometry figures over the points": (
        "critique --geometry {f}/points.csv --figures {f}/geometry_figures", 2, "would destroy the input"),
    "critique figures empty": ("critique {f}/campaign.csv --config {f}/cell.toml --figures=", 2, "--figures: expected the name of a folder"),
    "plan -o the cell": ("plan --config {f}/cell.toml -o {f}/cell.toml", 2, "the config this command reads"),
    "plan -o a link to the URDF": ("plan --config {f}/cell.toml -o {f}/urdf_link.csv", 2, "the robot URDF"),
    "study -o the cell": ("study q2-angles --config {f}/cell.toml -o {f}/cell.toml", 2, "the config this command reads"),
    "study --markdown the cell": ("study q2-angles --config {f}/cell.toml --markdown {f}/cell.toml", 2, "the config this command reads"),
    "study -o T --markdown T": ("study q2-angles --config {f}/cell.toml -o {f}/t.txt --markdown {f}/t.txt", 2, "also the output of"),
    "critique all-zero wrench": ("critique {f}/zero_wrench.csv --config {f}/cell.toml", 2, "every wrench"),
    "critique moments in N mm": ("critique {f}/moments_in_Nmm.csv --config {f}/cell.toml", 2, "N·mm"),
    "critique columns swapped": ("critique {f}/columns_swapped.csv --config {f}/cell.toml", 2, "swapped"),
    "critique wrench sign flipped": ("critique {f}/wrench_flipped.csv --config {f}/cell.toml", 2, "sign flipped"),
    "critique q2 beyond its limit": ("critique {f}/q2_beyond.csv --config {f}/cell.toml", 2, "outside its limits"),
    "critique geometry q2 in rad": ("critique --geometry {f}/points_rad.csv", 2, "are q2 in deg, not rad?"),
    "calibrate geometry is a calibration": (
        "calibrate {f}/campaign.csv --config {f}/cell.toml --geometry {f}/calibration.nc", 2, "elastostatic posterior"),
    "report plan hello": ("report --plan {f}/hello.json -o {f}/out", 2, "expected the key 'criterion'"),
    "report critique as the plan": ("report --plan {f}/critique.json -o {f}/out", 2, "bayescal plan --json"),
    "report verdict banana": ("report --critique {f}/banana.json -o {f}/out", 2, "'banana'"),
    "report any CSV as the study": ("report --study {f}/campaign.csv -o {f}/out", 2, "bayescal study q2-angles"),
    "report calibration beside another robot's campaign": (
        "report --calibration {f}/calibration.nc --campaign {f}/soft.csv --config {f}/cell.toml -o {f}/out", 2, "χ²/dof"),
    "plan evaluate a one-angle plan": ("plan --config {f}/cell.toml --evaluate {f}/one_angle_plan.csv", 2, "distinct q2 angle"),
    "plan evaluate a campaign": ("plan --config {f}/cell.toml --evaluate {f}/campaign.csv", 2, "this is a campaign"),
    "plan mass simulate refuses": ("plan --config {f}/cell.toml --mass-kg 1000 1200 -o {f}/p.csv", 2, "--mass-kg"),
    "plan mass 1e6": ("plan --config {f}/cell.toml --mass-kg 1e6 2e6 -o {f}/p.csv", 2, "--mass-kg"),
    "plan angles 1_0": ("plan --config {f}/cell.toml --angles 1_0 -o {f}/p.csv", 2, "--angles"),
    "plan marker 200 m out": ("plan --config {f}/cell_far_marker.toml -o {f}/p.csv", 2, "tool.markers_mm.M1"),
    "plan L in um": ("plan --config {f}/cell_L_in_um.toml -o {f}/p.csv", 2, "compensator.L_mm"),
    "study max angles 100000": ("study q2-angles --config {f}/cell.toml --max-angles 100000", 2, "--max-angles"),
}


def _run(capsys, argv: list[str]) -> tuple[int, list[str]]:
    status = main(argv)
    return status, capsys.readouterr().err.strip().splitlines()


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_case_exits_with_one_line_and_leaves_inputs_untouched(files, capsys, case):
    template, status, words = CASES[case]
    before = _digest(files)
    code, lines = _run(capsys, template.format(f=files).split())
    assert code == status and len(lines) == 1 and words in lines[0], lines
    assert _digest(files) == before
    assert not (files / "out").exists() and not (files / "p.csv").exists()


@pytest.mark.parametrize(
    ("name", "values"),
    [("metres", lambda p: [p.__setitem__(v, p[v] / 1000) for v in ("L", "a_x", "a_y")]), ("radians", lambda p: p.__setitem__("phi", np.deg2rad(p["phi"]))),
     ("nan", lambda p: p["L"].values.__setitem__((0, 3), np.nan))],
)
@pytest.mark.parametrize("command", ["calibrate", "report"])
def test_geometry_posteriors_in_other_units_or_with_nan_draws_are_refused(files, capsys, tmp_path, name, values, command):
    from bayescal.sampling.summary import load

    tree = load(files / "geometry.nc").load()
    posterior = tree["posterior"].to_dataset()
    values(posterior)
    tree["posterior"] = posterior
    path = tmp_path / f"{name}.nc"
    tree.to_netcdf(path)
    before = _digest(files) | _digest(tmp_path)
    extra = {"calibrate": ["calibrate", str(files / "campaign.csv"), "--config", str(files / "cell.toml")],
             "report": ["report", "--calibration", str(files / "calibration.nc"), "--campaign", str(files / "campaign.csv"),
                        "--config", str(files / "cell.toml"), "-o", str(tmp_path / "out")]}[command]
    code, lines = _run(capsys, extra + ["--geometry", str(path)])
    assert code == 2 and len(lines) == 1 and str(path) in lines[0], lines
    assert _digest(files) | _digest(tmp_path) == before


def _interrupt(*args, **kwargs):
    raise KeyboardInterrupt


@pytest.mark.parametrize(
    ("argv", "target"),
    [
        ("plan --config {f}/cell.toml --model linear -o {f}/p.csv", "bayescal.design.optimise.PlanDesigner.optimise"),
        ("study q2-angles --config {f}/cell.toml -o {f}/s.csv", "bayescal.design.angles.q2_angle_study"),
        ("report --plan {f}/plan.json -o {f}/out", "bayescal.reports.review.render_review"),
        ("calibrate {f}/campaign.csv --config {f}/cell.toml --posterior {f}/c.nc", "bayescal.inference.elastostatic.ElastostaticModel.fit"),
    ],
)
def test_ctrl_c_exits_130_with_one_line_and_nothing_written(files, capsys, monkeypatch, argv, target):
    monkeypatch.setattr(target, _interrupt)
    before = _digest(files)
    code, lines = _run(capsys, argv.format(f=files).split())
    assert code == 130 and lines == [f"bayescal {argv.split()[0]}: interrupted; nothing written"]
    assert _digest(files) == before


def test_ctrl_c_while_the_figures_are_written_leaves_no_half_png(files, capsys, monkeypatch, tmp_path):
    import bayescal.critique.figures as figures

    def half_then_interrupt(results, folder):
        (Path(folder) / "residuals.png").write_bytes(b"\x89PNG half")
        raise KeyboardInterrupt

    monkeypatch.setattr(figures, "write_figures", half_then_interrupt)
    monkeypatch.setattr("bayescal.critique.Critique.run", lambda self, campaign, rng, nests=None, repeats=False: None)
    (tmp_path / "figures").mkdir()
    code, lines = _run(capsys, ["critique", str(files / "campaign.csv"), "--config", str(files / "cell.toml"), "--figures", str(tmp_path / "figures")])
    assert code == 130 and len(lines) == 1 and lines[0].endswith("interrupted; nothing written")
    assert list((tmp_path / "figures").iterdir()) == []


def test_a_newton_failure_names_the_cell_and_the_load_option(files, capsys, monkeypatch):
    from bayescal.robot.stiffness import EquilibriumError

    def fail(*args, **kwargs):
        raise EquilibriumError("Newton's method did not converge in 30 iterations")

    monkeypatch.setattr("bayescal.design.optimise.PlanDesigner.optimise", fail)
    code, lines = _run(capsys, ["plan", "--config", str(files / "cell.toml"), "--mass-kg", "200", "250", "-o", str(files / "p.csv")])
    assert code == 2 and len(lines) == 1
    assert f"--config {files}/cell.toml" in lines[0] and "--mass-kg 200 250" in lines[0] and "no static equilibrium" in lines[0]


def test_a_failed_svd_names_the_inputs(files, capsys, monkeypatch):
    def degenerate(*args, **kwargs):
        raise np.linalg.LinAlgError("SVD did not converge")

    monkeypatch.setattr("bayescal.compensation.review.restore_results", degenerate)
    argv = ["report", "--calibration", str(files / "calibration.nc"), "--campaign", str(files / "campaign.csv"),
            "--config", str(files / "cell.toml"), "-o", str(files / "out")]
    code, lines = _run(capsys, argv)
    assert code == 2 and len(lines) == 1 and "SVD did not converge" in lines[0] and f"--calibration {files}/calibration.nc" in lines[0]


def test_a_calibration_of_a_robot_with_more_joints_is_refused(files, capsys, tmp_path):
    from bayescal.sampling.summary import load

    tree = load(files / "calibration.nc").load()
    posterior = tree["posterior"].to_dataset()
    posterior["k7"] = posterior["k6"]
    tree["posterior"] = posterior
    tree.to_netcdf(tmp_path / "seven.nc")
    argv = ["report", "--calibration", str(tmp_path / "seven.nc"), "--campaign", str(files / "campaign.csv"),
            "--config", str(files / "cell.toml"), "-o", str(tmp_path / "out")]
    code, lines = _run(capsys, argv)
    assert code == 2 and len(lines) == 1 and "is of a robot with 7 joints" in lines[0] and "has 6" in lines[0]


def test_a_full_disk_keeps_the_old_plan_and_names_the_output(files, capsys, monkeypatch, tmp_path):
    import errno

    from bayescal.design.optimise import PlanDesign

    def full(self, path, comments=()):
        Path(path).write_text("config,q1_deg\n1,")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr("bayescal.design.optimise.PlanDesigner.optimise", lambda self, *a, **k: PlanDesign.__new__(PlanDesign))
    monkeypatch.setattr(PlanDesign, "save", full)
    old = tmp_path / "plan.csv"
    old.write_text("the old plan\n")
    code, lines = _run(capsys, ["plan", "--config", str(files / "cell.toml"), "-o", str(old)])
    assert code == 2 and len(lines) == 1 and f"--output: cannot write {old} (No space left on device)" in lines[0]
    assert old.read_text() == "the old plan\n" and sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv"]


# ----------------------------------------------------------------- random output paths at every command

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

# Each command: its argv before the output, the output option, the names it writes into a folder output, its inputs.
COMMANDS = {
    "simulate": (["simulate", "--plan", "{f}/plan.csv", "--config", "{f}/cell.toml"], "-o", (), ("plan.csv", "cell.toml", "urdf")),
    "calibrate": (["calibrate", "{f}/campaign.csv", "--config", "{f}/cell.toml"], "--posterior", (), ("campaign.csv", "cell.toml", "urdf")),
    "geometry": (["geometry", "{f}/points.csv"], "--posterior", (), ("points.csv",)),
    "plan": (["plan", "--config", "{f}/cell.toml", "--model", "linear"], "-o", (), ("cell.toml", "urdf")),
    "study -o": (["study", "q2-angles", "--config", "{f}/cell.toml"], "-o", (), ("cell.toml", "urdf")),
    "study --markdown": (["study", "q2-angles", "--config", "{f}/cell.toml"], "--markdown", (), ("cell.toml", "urdf")),
    "critique": (
        ["critique", "{f}/campaign.csv", "--config", "{f}/cell.toml"], "--figures", ("residuals.png", "loo_pit.png"),
        ("campaign.csv", "cell.toml", "urdf"),
    ),
    "report": (["report", "--plan", "{f}/plan.json"], "-o", ("index.html", "summary.md", "numbers.json"), ("plan.json",)),
}
INPUTS = ("plan.csv", "cell.toml", "campaign.csv", "points.csv", "plan.json", "urdf")


@pytest.fixture(scope="module")
def property_inputs(files):
    """The inputs every command of :data:`COMMANDS` reads, side by side in one folder."""
    folder = files / "property"
    folder.mkdir()
    for name in ("cell.toml", "campaign.csv", "points.csv", "plan.json"):
        (folder / name).write_bytes((files / name).read_bytes())
    (folder / "plan.csv").write_bytes((DATA / "table3_plan.csv").read_bytes())
    (folder / "cell.toml").write_text((folder / "cell.toml").read_text().replace(f'"{DATA}/robots/kr270.urdf"', '"robots/kr270.urdf"'))
    (folder / "robots").mkdir()
    (folder / "robots" / "kr270.urdf").write_bytes(URDF.read_bytes())
    return folder


def _hostile_path(folder: Path, kind: str, target: str, names: tuple[str, ...], index: int) -> str:
    """An output path of ``kind`` aimed at the input ``target``, made under ``folder``."""
    source = folder / ("robots/kr270.urdf" if target == "urdf" else target)
    work = folder / f"try{index}"
    work.mkdir()
    if kind == "the input":
        return str(source)
    if kind == "a dotted path to the input":
        return f"{work}/../{source.relative_to(folder)}"
    if kind in ("a symlink", "a hard link"):
        link = work / (names[index % len(names)] if names else "out.csv")
        (os.symlink if kind == "a symlink" else os.link)(source, link)
        return str(work if names else link)
    if kind == "a path under a file":
        return f"{source}/out"
    if kind == "a missing folder":
        return str(work / "missing" / "out")
    return str(work)  # an existing folder: refused as a file; as a folder it holds a link to an input (below)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    command=st.sampled_from(list(COMMANDS)),
    kind=st.sampled_from(["the input", "a dotted path to the input", "a symlink", "a hard link", "a path under a file", "a missing folder", "an existing folder"]),
    pick=st.integers(0, 2),
    index=st.integers(0, 10**6),
)
def test_no_output_path_overwrites_an_input(property_inputs, capsys, command, kind, pick, index):
    head, option, names, reads = COMMANDS[command]
    target = reads[pick % len(reads)]
    folder = property_inputs
    if (folder / f"try{index}").exists():
        return
    path = _hostile_path(folder, kind, target, names, index)
    if kind == "an existing folder" and names:
        os.symlink(folder / ("robots/kr270.urdf" if target == "urdf" else target), Path(path) / names[index % len(names)])
    before = {name: (folder / ("robots/kr270.urdf" if name == "urdf" else name)).read_bytes() for name in INPUTS}
    status = main([word.format(f=folder) for word in head] + [option, path])
    lines = capsys.readouterr().err.strip().splitlines()
    after = {name: (folder / ("robots/kr270.urdf" if name == "urdf" else name)).read_bytes() for name in INPUTS}
    assert status == 2 and len(lines) == 1, (command, kind, target, lines)
    assert after == before
    assert not [p for p in folder.rglob("*.tmp*")]
