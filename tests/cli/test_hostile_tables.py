"""Hostile joint-angle tables: programs checked like campaigns, campaigns whose columns are swapped, sweeps with a
joint the robot lacks.  Each is refused in one line naming the file, line and column, exit status 2, every input
byte-identical and nothing written.

The tables share one reader (:mod:`bayescal.cell.joint_tables`); a campaign's swap is named only when undoing it
makes the data what an arm produces (markers on one point of the tool, deflections along the forces).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bayescal.cli import main
from bayescal.twin.sweeps import random_placement, simulate_sweeps

DATA = Path(__file__).resolve().parents[2] / "data"
HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]
JOINTS = [f"q{j}_deg" for j in range(1, 7)]
POSITIONS = ["x0_mm", "y0_mm", "z0_mm", "x1_mm", "y1_mm", "z1_mm"]


def _digest(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` and the hash of its bytes."""
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*")) if p.is_file()}


def _swap(frame: pd.DataFrame, pairs: dict[str, str]) -> pd.DataFrame:
    """``frame`` with the columns of each pair exchanged, in the original column order."""
    return frame.rename(columns=pairs | {b: a for a, b in pairs.items()})[list(frame.columns)]


@pytest.fixture(scope="module")
def files(tmp_path_factory, cell, short_calibration):
    """A campaign written by `bayescal simulate`, programs for `compensate`, sweeps for `axes`, and hostile edits of each."""
    folder = tmp_path_factory.mktemp("hostile_tables")
    cell_text = (DATA / "kr270.toml").read_text().replace('urdf = "', f'urdf = "{DATA}/').replace('reference_csv = "', f'reference_csv = "{DATA}/')
    (folder / "cell.toml").write_text(cell_text)
    (folder / "calibration.nc").write_bytes(Path(short_calibration["calibration"]).read_bytes())
    assert main(["simulate", "--plan", str(DATA / "table3_plan.csv"), "--config", str(folder / "cell.toml"), "-o", str(folder / "c.csv")]) == 0
    campaign = pd.read_csv(folder / "c.csv", comment="#")
    tables = {
        "c_fx_fz": _swap(campaign, {"fx_N": "fz_N"}),
        "c_x_y": _swap(campaign, {"x0_mm": "y0_mm", "x1_mm": "y1_mm"}),
        "c_x_z": _swap(campaign, {"x0_mm": "z0_mm", "x1_mm": "z1_mm"}),
        "c_metres": campaign.assign(**{name: campaign[name] / 1000 for name in POSITIONS}),
        "c_rad": campaign.assign(**{name: np.radians(campaign[name]) for name in JOINTS}),
        "c_q7": campaign.assign(q7_deg=0.0),
        "c_load_300m": campaign.assign(load_x_mm=300000.0, load_y_mm=0.0, load_z_mm=0.0),
    }
    program = pd.read_csv(DATA / "table3_plan.csv", comment="#")[JOINTS].assign(
        fx_N=-800.0, fy_N=0.0, fz_N=-200.0, mx_Nm=0.0, my_Nm=0.0, mz_Nm=0.0)
    tables |= {
        "p_rad": program.assign(**{name: np.radians(program[name]) for name in JOINTS}),
        "p_q7": program.assign(q7_deg=0.0),
        "p_tcp_300m": program.assign(tcp_x_mm=300000.0, tcp_y_mm=0.0, tcp_z_mm=0.0),
        "p_flag": program.assign(flag="keep"),
        "p_cmd": program.assign(q1_cmd_deg=1.0),
        "p_error": program.assign(error_q9973_mm=0.1),
    }
    rng = np.random.default_rng(7)
    sweeps = simulate_sweeps(cell, random_placement(rng), rng, home_deg=HOME)
    tables |= {"s_q7": sweeps.assign(q7_deg=0.0), "s_q6_rad": sweeps.rename(columns={"q6_deg": "q6_rad"})}
    for name, table in tables.items():
        table.to_csv(folder / f"{name}.csv", index=False)
    return folder


# Each case: the command, the table, and words its one line must hold (exit status 2).
CASES = {
    ("critique", "c_fx_fz"): "fx_N': the markers move across the load force (median angle 94 deg between deflection and force, "
    "over 135 rows) but along it with fx_N and fz_N exchanged (16 deg): are the columns fx_N and fz_N swapped?",
    ("critique", "c_x_y"): "'x0_mm': marker 'M2' is 5.77 m from the flange, farther than any tool (2 m): with x and y exchanged, "
    "every marker sits on one point of the tool (to 0.1 mm): are x and y swapped",
    ("critique", "c_x_z"): "with x and z exchanged, every marker sits on one point of the tool (to 0.1 mm): are x and z swapped",
    ("critique", "c_metres"): "read in mm, every marker sits on one point of the tool (to 0.1 mm): are x0_mm..z1_mm in metres instead of mm?",
    ("critique", "c_rad"): "c_rad.csv:2, column 'q1_deg': every joint angle of the 15 configurations lies within ±3.2 deg",
    ("critique", "c_q7"): "c_q7.csv:1, column 'q7_deg': the campaign has a column q7_deg but the robot",
    ("critique", "c_load_300m"): "c_load_300m.csv:2, column 'load_x_mm': a tool point 300 m from the flange, farther than the robot reaches (3.735 m",
    ("calibrate", "c_fx_fz"): "are the columns fx_N and fz_N swapped?",
    ("calibrate", "c_x_y"): "are x and y swapped (x0_mm with y0_mm, x1_mm with y1_mm), a mirrored frame?",
    ("calibrate", "c_metres"): "are x0_mm..z1_mm in metres instead of mm?",
    ("calibrate", "c_rad"): "as angles in radians would: write q1_deg..q6_deg in degrees",
    ("compensate", "p_rad"): "p_rad.csv:2, column 'q1_deg': every joint angle of the 15 configurations lies within ±3.2 deg, as angles in "
    "radians would: write q1_deg..q6_deg in degrees",
    ("compensate", "p_q7"): "p_q7.csv:1, column 'q7_deg': the program has a column q7_deg but the robot",
    ("compensate", "p_tcp_300m"): "p_tcp_300m.csv:2, column 'tcp_x_mm': a tool point 300 m from the flange, farther than the robot reaches "
    "(3.735 m, the sum of its links' lengths in",
    ("compensate", "p_flag"): "p_flag.csv:1, column 'flag': the program has a column flag, which the compensated file writes "
    "(its values would be overwritten): rename it",
    ("compensate", "p_cmd"): "column 'q1_cmd_deg': the program has a column q1_cmd_deg, which the compensated file writes",
    ("compensate", "p_error"): "column 'error_q9973_mm': the program has a column error_q9973_mm, which the compensated file writes",
    ("axes", "s_q7"): "s_q7.csv:1, column 'q7_deg': the sweep file has a column q7_deg but the robot",
    ("axes", "s_q6_rad"): "s_q6_rad.csv:1, column 'q6_rad': the sweep file has a column q6_rad where the robot",
}
OUTPUT = {
    "critique": "",
    "calibrate": " --posterior {f}/out.nc",
    "compensate": " --calibration {f}/calibration.nc -o {f}/out.csv",
    "axes": " -o {f}/out.json",
}


@pytest.mark.parametrize("case", list(CASES), ids=[" ".join(case) for case in CASES])
def test_hostile_table_exits_2_with_one_line_and_writes_nothing(files, capsys, case):
    command, table = case
    argv = f"{command} {{f}}/{table}.csv --config {{f}}/cell.toml{OUTPUT[command]}".format(f=files).split()
    before = _digest(files)
    status = main(argv)
    lines = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and CASES[case] in lines[0] and "Traceback" not in lines[0], lines
    assert _digest(files) == before
    assert not [p for p in files.iterdir() if p.name.startswith("out") or ".tmp" in p.name]


def test_the_unswapped_campaign_and_program_pass(files, capsys, tmp_path):
    assert main(["critique", str(files / "c.csv"), "--config", str(files / "cell.toml")]) == 0
    program = pd.read_csv(files / "p_flag.csv").drop(columns=["flag"])
    program.to_csv(tmp_path / "p.csv", index=False)
    out = tmp_path / "out.csv"
    assert main(["compensate", str(tmp_path / "p.csv"), "--calibration", str(files / "calibration.nc"), "--config",
                 str(files / "cell.toml"), "-o", str(out)]) == 0
    assert len(pd.read_csv(out)) == 15
