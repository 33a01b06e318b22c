"""The registration on real laser-tracker sweeps (Boby and Klimchik's published data set), read in place."""

from __future__ import annotations

from pathlib import Path

import pytest

from bayescal.registration import read_sweeps, register

SWEEPS = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "boby-sweeps" / "sweeps.csv"
"""Boby and Klimchik's sweeps (RABKKK/LaserTrackerPoseData4KinIdent, N1N2N3Jval.csv), never copied into the repository."""


@pytest.fixture(scope="module")
def registration(cell):
    if not SWEEPS.is_file():
        pytest.skip(f"the real sweeps are not at {SWEEPS} (file N1N2N3Jval.csv of RABKKK/LaserTrackerPoseData4KinIdent, "
                    "without its rows that move joints 2 and 3 together)")
    # Read without the robot: the data set's robot turns A4 and A6 through ±360°, beyond the KR-270's ±350° limits;
    # only the tracker's noise law and the joint count of the cell are used, since no frame can be built.
    return register(read_sweeps(SWEEPS), cell)


def test_real_scatter_is_learned_not_refused(registration):
    assert sorted(registration.axes) == [0, 2, 3, 4, 5]
    excess = {j + 1: fit.excess for j, fit in registration.axes.items()}
    # Measured: 2.94, 6.66, 2.44, 3.40, 2.42 times the KR-270 cell's tracker law.
    assert all(2.0 < e < 8.0 for e in excess.values()), excess
    assert all(fit.beyond_tracker for fit in registration.axes.values())
    # Joint 1's direction sd, clustered by swept angle, is measured 0.0744 mrad (0.033 mrad from the tracker's law
    # alone) with 2.2 degrees of freedom (six angles), so the interval with the normal's ±3 sd coverage is ±1.14 mrad,
    # Student's t quantile 15.3 sd.
    first = registration.axes[0]
    assert first.direction_sd * 1e3 == pytest.approx(0.0744, rel=0.02)
    assert first.direction_dof == pytest.approx(2.22, abs=0.05)
    assert first.half_widths()["direction_mrad"]["3"] == pytest.approx(1.138, rel=0.02)


def test_without_joint_2_the_missing_sweep_is_named(registration):
    assert registration.frames == {} and registration.left_out == {}
    assert registration.missing.startswith("no base frame and no paper frame: sweep joint 2")
    payload = registration.to_json()
    assert payload["missing"] == registration.missing and set(payload["axes"]) == {"1", "3", "4", "5", "6"}



def test_the_command_reads_the_real_file_with_the_kr270_cell_and_warns_of_the_limits(capsys, tmp_path):
    from bayescal.cli import main

    if not SWEEPS.is_file():
        pytest.skip(f"the real sweeps are not at {SWEEPS}")
    config = Path(__file__).resolve().parents[2] / "data" / "kr270.toml"
    out = tmp_path / "registration.json"
    assert main(["axes", str(SWEEPS), "--config", str(config), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    # A4 and A6 swept through ±360°, beyond the KR-270's ±350°: warned of, not refused (the axis fit needs no limit).
    assert "beyond its limits" in captured.err and "is the cell's URDF the swept robot's?" in captured.err
    assert "sweep joint 2" in captured.out and out.is_file()
    # The file written is read back by calibrate's loader, which names what it lacks.
    from bayescal.errors import InputError
    from bayescal.registration.register import read_frame

    with pytest.raises(InputError, match="no base frame: sweep joint 2"):
        read_frame(out, "base")
