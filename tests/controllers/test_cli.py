"""``bayescal compensate`` on KRL and RAPID programs: the files written, and the bad inputs refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bayescal.cli as cli


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("compensate",))
    return cli.main


@pytest.fixture(scope="module")
def small(robot, programs):
    """20 targets: small programs for the command line's tests."""
    return programs.draw_targets(robot, 20, np.random.default_rng(5))


def _krl(folder, programs, drawn, *, dat=None):
    src, text = programs.krl_texts(drawn)
    (folder / "mill.src").write_text(src)
    (folder / "mill.dat").write_text(dat(text) if dat else text)
    (folder / "wrenches.csv").write_text(programs.wrench_csv(drawn, "X", "XHOME"))
    return folder / "mill.src"


def _run(main, program, calibration, out, *extra):
    return main(["compensate", str(program), "--calibration", str(calibration["calibration"]), "--config", str(calibration["config"]), "-o", str(out), *extra])


def test_a_krl_program_is_written_back_as_krl(main, short_calibration, programs, small, tmp_path, capsys):
    program = _krl(tmp_path, programs, small)
    before = {name: (tmp_path / name).read_bytes() for name in ("mill.src", "mill.dat")}
    assert _run(main, program, short_calibration, tmp_path / "out.src", "--wrenches", str(tmp_path / "wrenches.csv"), "--json") == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["program"] == {
        "language": "KRL", "targets": 21, "cartesian_targets": 20, "joint_targets": 1,
        "motions": payload["program"]["motions"], "unsupported_statements_passed_through": 4 + (tmp_path / "mill.src").read_text().count("$OUT"),
    }
    assert (tmp_path / "out.src").read_bytes() == before["mill.src"]
    assert (tmp_path / "out.dat").read_text().count("; bayescal: compensated, 99.73 % error bound") == 21
    assert {name: (tmp_path / name).read_bytes() for name in ("mill.src", "mill.dat")} == before


def test_one_wrench_for_every_target_of_a_rapid_program(main, short_calibration, programs, small, tmp_path, capsys):
    path = tmp_path / "mill.mod"
    path.write_text(programs.rapid_text(small))
    assert _run(main, path, short_calibration, tmp_path / "out.mod", "--wrench", "0,0,-800,0,0,0") == 0
    assert "RAPID: 21 targets (20 Cartesian, 1 joint)" in capsys.readouterr().out
    assert (tmp_path / "out.mod").read_text().count("! bayescal: compensated") == 21


def _without_status(text):
    first = next(line for line in text.splitlines() if line.startswith("DECL E6POS"))
    return text.replace(first, first.split(",S ")[0] + ",E1 0.0}")


def _in_radians(text):
    return text.replace("XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 45.0,A6 0.0", "XHOME={A1 0.0,A2 -1.5708,A3 1.5708,A4 0.0,A5 0.7854,A6 0.0")


@pytest.mark.parametrize(
    "case, expected",
    [
        ("no status", r"mill\.dat:9, column 'S': a Cartesian target without 'S' and 'T'"),
        ("radians", r"mill\.dat:7, column 'A1': every axis angle of the 2 joint targets lies within ±3\.2 deg"),
        ("unknown target", r"wrenches\.csv:23, column 'target': target 'XP99' is not moved to by mill\.src"),
        ("other wobj", r"mill\.mod:\d+, column '\d+': work object 'fixture' is not declared in this module"),
        ("csv with wrench", r"--wrench: a CSV program gives each row's wrench"),
        ("no wrench", r"--wrench: a KRL or RAPID program carries no process wrench"),
    ],
)
def test_bad_inputs_are_one_line_exit_2_and_nothing_written(main, short_calibration, programs, small, tmp_path, capsys, case, expected):
    extra = ["--wrenches", str(tmp_path / "wrenches.csv")]
    out = tmp_path / "out.src"
    if case == "no status":
        program = _krl(tmp_path, programs, small, dat=_without_status)
    elif case == "radians":
        program = _krl(tmp_path, programs, small, dat=lambda text: _in_radians(text).replace(
            "DECL FDAT", "DECL E6AXIS XPARK={A1 0.5,A2 -1.0,A3 1.2,A4 0.1,A5 0.9,A6 0.2}\nDECL FDAT"))
        src = program.read_text().replace("PTP XHOME\n", "PTP XHOME\nPTP XPARK\n", 1)
        program.write_text(src)
        (tmp_path / "wrenches.csv").write_text((tmp_path / "wrenches.csv").read_text() + "XPARK,0,0,0,0,0,0\n")
    elif case == "unknown target":
        program = _krl(tmp_path, programs, small)
        (tmp_path / "wrenches.csv").write_text((tmp_path / "wrenches.csv").read_text() + "XP99,0,0,-100,0,0,0\n")
    elif case == "other wobj":
        program = tmp_path / "mill.mod"
        program.write_text(programs.rapid_text(small).replace("spindle\\WObj:=table;", "spindle\\WObj:=fixture;", 1))
        extra, out = ["--wrench", "0,0,-800,0,0,0"], tmp_path / "out.mod"
    elif case == "csv with wrench":
        program = tmp_path / "program.csv"
        program.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,fx_N,fy_N,fz_N,mx_Nm,my_Nm,mz_Nm\n0,-50,80,0,-30,0,0,0,-500,0,0,0\n")
        extra, out = ["--wrench", "0,0,-800,0,0,0"], tmp_path / "out.csv"
    else:
        program = _krl(tmp_path, programs, small)
        extra = []
    before = sorted(p.name for p in tmp_path.iterdir())
    assert _run(main, program, short_calibration, out, *extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert __import__("re").search(expected, err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == before
