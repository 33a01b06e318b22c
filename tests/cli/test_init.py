"""Tests of bayescal.cli: malformed and hostile input across the subcommands.

Every case must end with exit status 2 and one line on stderr naming the file,
line and column (or the option) at fault, with no traceback, and must leave
every input file byte for byte as it was and write no output.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from bayescal.cli import main
from bayescal.units import DEG

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture
def workspace(tmp_path, campaign_csv, monkeypatch):
    """The cell, the Table III plan, Table I and a twin campaign copied into an empty folder, the working directory."""
    shutil.copytree(DATA / "robots", tmp_path / "robots")
    shutil.copy(DATA / "kr270.toml", tmp_path / "cell.toml")
    shutil.copy(DATA / "table3_plan.csv", tmp_path / "plan.csv")
    shutil.copy(DATA / "table1_geometry.csv", tmp_path / "points.csv")
    shutil.copy(campaign_csv, tmp_path / "campaign.csv")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def edit_csv(name, column, change, rows=lambda fields, header: True):
    """Apply ``change(value)`` to ``column`` in the data rows of ``name`` that ``rows`` selects."""
    lines = Path(name).read_text().splitlines()
    header_at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    header = lines[header_at].split(",")
    at = header.index(column)
    for i in range(header_at + 1, len(lines)):
        fields = lines[i].split(",")
        if rows(fields, header):
            fields[at] = change(fields[at])
            lines[i] = ",".join(fields)
    Path(name).write_text("\n".join(lines) + "\n")


def edit_text(name, old, new):
    text = Path(name).read_bytes()
    assert old in text
    Path(name).write_bytes(text.replace(old, new, 1))


def copy_unloaded_into_loaded(name):
    """Overwrite x1_mm, y1_mm, z1_mm (the last three columns) by x0_mm, y0_mm, z0_mm in every data row."""
    lines = Path(name).read_text().splitlines()
    data = [not line.startswith("#") and not line.startswith("config") for line in lines]
    lines = [",".join([*line.split(",")[:-3], *line.split(",")[-6:-3]]) if row else line for line, row in zip(lines, data)]
    Path(name).write_text("\n".join(lines) + "\n")


def scaled(factor):
    return lambda value: f"{float(value) * factor:.8g}"


def config_3(fields, header):
    return fields[header.index("config")] == "3"


def rename_column(name, old, new):
    edit_text(name, old.encode(), new.encode())


WRENCH = ("fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm")
GEOMETRY = ["geometry", "points.csv", "--tune", "10", "--draws", "10"]
SIMULATE = ["simulate", "--plan", "plan.csv", "--config", "cell.toml", "-o", "out.csv"]
CALIBRATE = ["calibrate", "campaign.csv", "--config", "cell.toml", "--draws", "100"]


# (id, prepare the workspace, argv, fragments the one-line message must hold)
CASES = [
    # geometry
    ("points in metres", lambda: [edit_csv("points.csv", c, scaled(1e-3)) for c in ("x_mm", "y_mm")], GEOMETRY,
     ["points.csv:8, column 'x_mm'", "in metres instead of mm"]),
    ("points in micrometres", lambda: edit_csv("points.csv", "x_mm", scaled(1e3)), GEOMETRY,
     ["points.csv:", "column 'x_mm'", "beyond any tracker's range"]),
    ("underscore in an angle", lambda: edit_text("points.csv", b"\n-30,P1,", b"\n-3_0,P1,"), GEOMETRY,
     ["points.csv:11, column 'q2_deg'", "got '-3_0'"]),
    ("semicolons", lambda: Path("points.csv").write_text(Path("points.csv").read_text().replace(",", ";")), GEOMETRY,
     ["points.csv:7:", "separated by ';'"]),
    ("posterior onto the points", None, [*GEOMETRY, "--posterior", "points.csv"], ["--posterior: points.csv is the points file"]),
    ("posterior onto the reference", lambda: shutil.copy(DATA / "paper_reference.csv", "ref.csv"),
     [*GEOMETRY, "--reference", "ref.csv", "--posterior", "./ref.csv"], ["--posterior: ./ref.csv is the --reference file (ref.csv)"]),
    ("posterior in a missing folder", None, [*GEOMETRY, "--posterior", "none/post.nc"], ["--posterior: the output folder", "does not exist"]),
    ("points file is a folder", lambda: os.mkdir("dir.csv"), ["geometry", "dir.csv"], ["dir.csv: is a folder"]),
    ("geometry negative seed", None, [*GEOMETRY, "--seed", "-1"], ["argument --seed: expected a whole number >= 0"]),
    ("one chain", None, [*GEOMETRY, "--chains", "1"], ["argument --chains: expected a whole number >= 2"]),
    # simulate
    ("output onto the plan", None, [*SIMULATE[:-1], "plan.csv"], ["-o: plan.csv is the plan"]),
    ("output onto the config", None, [*SIMULATE[:-1], "./cell.toml"], ["-o: ./cell.toml is the config (cell.toml)"]),
    ("output onto the URDF", None, [*SIMULATE[:-1], "robots/kr270.urdf"], ["-o: robots/kr270.urdf is the robot URDF"]),
    ("output through a symlink to the plan", lambda: os.symlink("plan.csv", "link.csv"), [*SIMULATE[:-1], "link.csv"],
     ["-o: link.csv is the plan (plan.csv)"]),
    ("output onto a folder", lambda: os.mkdir("out"), [*SIMULATE[:-1], "out"], ["-o: out is a directory"]),
    ("underscore in a plan cell", lambda: edit_text("plan.csv", b"\n95.00,-25.24,33.00", b"\n95.00,-2_5.24,33.00"), SIMULATE,
     ["plan.csv:11, column 'q2_deg'", "got '-2_5.24'"]),
    ("plan with a seventh joint", lambda: rename_column("plan.csv", "q6_deg,load_kg", "q6_deg,q7_deg"), SIMULATE,
     ["plan.csv:7, column 'q7_deg'", "has 6 joints: expected the columns q1_deg..q6_deg"]),
    ("plan load in grams", lambda: edit_csv("plan.csv", "load_kg", scaled(1e3)), SIMULATE,
     ["plan.csv:8, column 'load_kg'", "more than the 540 kg the arm can plausibly carry"]),
    ("TOML key typo", lambda: edit_text("cell.toml", b"\nfactor = 0.8", b"\nfactr = 0.1"), SIMULATE,
     ["cell.toml:", "column 'tracker.factr'", "did you mean 'factor'?"]),
    ("TOML Latin-1 byte", lambda: edit_text("cell.toml", b"# Leica", b"# Leica \xe9"), SIMULATE,
     ["cell.toml:", "byte 0xe9 is not UTF-8"]),
    ("negative spring stiffness", lambda: edit_text("cell.toml", b"K_c_N_per_mm = 144.0", b"K_c_N_per_mm = -144.0"), SIMULATE,
     ["column 'compensator.K_c_N_per_mm'", "expected a number >= 0 in N/mm"]),
    ("URDF not XML", lambda: Path("robots/kr270.urdf").write_text("not xml\n"), SIMULATE,
     ["robots/kr270.urdf:1: not a URDF: not valid XML"]),
    ("effect too large for the arm", None, [*SIMULATE, "--effect", "backlash=1e6"],
     ["plan.csv:8", "with the effects backlash=1e+06 deg: is an --effect magnitude too large?"]),
    ("effect magnitude with an underscore", None, [*SIMULATE, "--effect", "backlash=1_5"],
     ["argument --effect: expected NAME=MAGNITUDE with a plain decimal number, got 'backlash=1_5'"]),
    ("URDF is a folder", lambda: edit_text("cell.toml", b'"robots/kr270.urdf"', b'"robots"'), SIMULATE,
     ["robots: is a folder; expected a URDF file"]),
    ("simulate negative seed", None, [*SIMULATE, "--seed", "-1"], ["argument --seed"]),
    ("zero repeats", None, [*SIMULATE, "--repeats", "0"], ["argument --repeats: expected a whole number >= 1, got 0"]),
    ("unknown effect", None, [*SIMULATE, "--effect", "wobble"], ["--effect: unknown effect 'wobble'"]),
    # calibrate
    ("posterior onto the campaign", None, [*CALIBRATE, "--posterior", "campaign.csv"], ["--posterior: campaign.csv is the campaign"]),
    ("posterior onto the config", None, [*CALIBRATE, "--posterior", "cell.toml"], ["--posterior: cell.toml is the config"]),
    ("posterior onto the geometry", None, [*CALIBRATE, "--geometry", "geo.nc", "--posterior", "geo.nc"],
     ["--posterior: geo.nc is the --geometry posterior"]),
    ("wrench 1000 times too large", lambda: [edit_csv("campaign.csv", c, scaled(1e3)) for c in WRENCH], CALIBRATE,
     ["campaign.csv:", "column 'fz_N'", "is the wrench in another unit"]),
    ("wrench in kN", lambda: [edit_csv("campaign.csv", c, scaled(1e-3)) for c in WRENCH], CALIBRATE,
     ["campaign.csv:", "column 'fz_N'", "in kN instead of N"]),
    ("a force of 1e12 N", lambda: edit_csv("campaign.csv", "fz_N", lambda v: "-1e12", config_3), CALIBRATE,
     ["campaign.csv:9, column 'fz_N'", "1e+12 N"]),
    ("moments in N mm", lambda: [edit_csv("campaign.csv", c, scaled(1e3)) for c in WRENCH[3:]], CALIBRATE,
     ["campaign.csv:3, column 'm", "in N·mm instead of N·m"]),
    ("q2 beyond its limit", lambda: edit_csv("campaign.csv", "q2_deg", lambda v: "200", config_3), CALIBRATE,
     ["campaign.csv:9, column 'q2_deg'", "outside its limits"]),
    ("angles in radians", lambda: [edit_csv("campaign.csv", f"q{j}_deg", scaled(DEG)) for j in range(1, 7)], CALIBRATE,
     ["campaign.csv:3, column 'q1_deg'", "in degrees"]),
    ("five joint columns", lambda: rename_column("campaign.csv", "q6_deg", "extra"), CALIBRATE,
     ["campaign.csv:2, column 'q6_deg'", "expected the columns q1_deg..q6_deg"]),
    ("seven joint columns", lambda: rename_column("campaign.csv", "fx_N", "q7_deg"), CALIBRATE,
     ["campaign.csv:2, column 'q7_deg'", "robot (robots/kr270.urdf) has 6 joints"]),
    ("underscore in a campaign cell", lambda: edit_csv("campaign.csv", "x1_mm", lambda v: "7_9.20", config_3), CALIBRATE,
     ["campaign.csv:9, column 'x1_mm'", "got '7_9.20'"]),
    ("loaded positions copied from the unloaded ones", lambda: copy_unloaded_into_loaded("campaign.csv"), CALIBRATE, ["campaign.csv:3, column 'x1_mm'", "were the unloaded columns copied"]),
    ("calibrate with a Latin-1 TOML", lambda: edit_text("cell.toml", b"# Leica", b"# Leica \xb5"), CALIBRATE,
     ["cell.toml:", "byte 0xb5"]),
    ("geometry posterior is a folder", None, [*CALIBRATE, "--geometry", "robots"], ["robots: is a folder; expected the NetCDF file"]),
    ("empty output name", None, [*CALIBRATE, "--posterior", ""], ["--posterior: expected the name of a file to write"]),
    ("a table given as a value", lambda: Path("cell.toml").write_text("# a cell\nrobot = 3\n"), CALIBRATE,
     ["cell.toml:2, column 'robot': expected the table [robot], got the value 3"]),
    ("calibrate negative seed", None, [*CALIBRATE, "--seed", "-1"], ["argument --seed"]),
    ("too few draws", None, [*CALIBRATE, "--draws", "50"], ["argument --draws: expected a whole number >= 100"]),
]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


@pytest.mark.parametrize(("prepare", "argv", "fragments"), [case[1:] for case in CASES], ids=[case[0] for case in CASES])
def test_malformed_input_exits_2_with_one_line_and_touches_nothing(workspace, capfd, prepare, argv, fragments):
    if prepare is not None:
        prepare()
    before = _snapshot(workspace)
    status = main(argv)
    # capfd, not capsys: a C++ parser under Pinocchio writes to the file descriptor directly.
    err = capfd.readouterr().err.strip()
    assert status == 2
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith(f"bayescal {argv[0]}: error: ")
    for fragment in fragments:
        assert fragment in err
    assert _snapshot(workspace) == before
