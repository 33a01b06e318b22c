"""``bayescal kinematics`` and ``predict`` as a user runs them, and their answers to bad input."""

import numpy as np
import pandas as pd
import pytest

from bayescal.cli import main

from .conftest import JUSTIN_CELL, simulated, write_positions


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory, justin):
    _, _, joints, xyz = simulated(justin, "geometry", np.random.default_rng(5), 60)
    return write_positions(tmp_path_factory.mktemp("kin") / "positions.csv", justin, joints, xyz)


def test_kinematics_then_predict_in_the_given_order(tmp_path, small_campaign, capsys):
    calibration = tmp_path / "cal.nc"
    assert main(["kinematics", str(small_campaign), "--config", str(JUSTIN_CELL), "--model", "geometry", "-o", str(calibration)]) == 0
    assert "identified by the data" in capsys.readouterr().out
    measured = pd.read_csv(small_campaign)
    asked = measured.drop(columns=["x_mm", "y_mm", "z_mm"]).iloc[::-1]
    asked_file = tmp_path / "asked.csv"
    asked.to_csv(asked_file, index=False)
    out = tmp_path / "predicted.csv"
    assert main(["predict", str(asked_file), "--calibration", str(calibration), "--config", str(JUSTIN_CELL), "-o", str(out)]) == 0
    predicted = pd.read_csv(out)
    assert list(predicted["marker"]) == list(asked["marker"])
    assert np.allclose(predicted["q1_deg"], asked["q1_deg"], atol=1e-4)
    expected = measured.iloc[::-1][["x_mm", "y_mm", "z_mm"]].to_numpy()
    assert np.abs(predicted[["x_mm", "y_mm", "z_mm"]].to_numpy() - expected).max() < 2.0
    assert (predicted[["x_sd_mm", "y_sd_mm", "z_sd_mm"]] > 0).all().all()


def test_an_extension_rung_fits_saves_and_predicts(tmp_path, small_campaign, capsys):
    """``--model coupled-elastic`` (beyond the published ladder) writes a calibration that ``predict`` reads back."""
    calibration = tmp_path / "cal.nc"
    assert main(["kinematics", str(small_campaign), "--config", str(JUSTIN_CELL), "--model", "coupled-elastic", "-o", str(calibration),
                 "--json"]) == 0
    import json

    names = [row["parameter"] for row in json.loads(capsys.readouterr().out)["parameters"]]
    assert "base.shift_x_per_My" in names and "torso3_joint.k_theta.torso4_joint" in names
    asked = tmp_path / "asked.csv"
    pd.read_csv(small_campaign).drop(columns=["x_mm", "y_mm", "z_mm"]).to_csv(asked, index=False)
    out = tmp_path / "predicted.csv"
    assert main(["predict", str(asked), "--calibration", str(calibration), "--config", str(JUSTIN_CELL), "-o", str(out)]) == 0
    predicted = pd.read_csv(out)[["x_mm", "y_mm", "z_mm"]].to_numpy()
    assert np.abs(predicted - pd.read_csv(small_campaign)[["x_mm", "y_mm", "z_mm"]].to_numpy()).max() < 2.0


def _edit(source, target, change):
    frame = change(pd.read_csv(source))
    frame.to_csv(target, index=False)
    return target


BAD = {
    "unknown marker": (lambda f: f.assign(marker=f["marker"].replace("left", "elbow")), "unknown marker 'elbow'"),
    "one hand missing": (lambda f: f.drop(index=3), "no row for marker"),
    "metres": (lambda f: f.assign(x_mm=f.x_mm / 1000, y_mm=f.y_mm / 1000, z_mm=f.z_mm / 1000), "metres?"),
    "radians": (lambda f: f.assign(**{c: np.radians(f[c]) / 2 for c in f.columns if c.startswith("q")}), "as angles in radians would"),
    "joint count": (lambda f: f.drop(columns=["q19_deg"]), "has no column q19_deg but the cell"),
    "joint in rad": (lambda f: f.rename(columns={"q3_deg": "q3_rad"}), "column 'q3_rad': the positions file has a column q3_rad where the cell"),
    "a joint more": (lambda f: f.assign(q20_deg=0.0), "column 'q20_deg': the positions file has a column q20_deg but the cell"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_positions_one_line_exit_2_nothing_written(case, tmp_path, small_campaign, capsys):
    change, expected = BAD[case]
    bad = _edit(small_campaign, tmp_path / "bad.csv", change)
    before = bad.read_bytes()
    out = tmp_path / "cal.nc"
    assert main(["kinematics", str(bad), "--config", str(JUSTIN_CELL), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and len(err.splitlines()) == 1 and "Traceback" not in err
    assert not out.exists() and bad.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["bad.csv"]


def test_output_onto_the_cells_urdf_is_refused(tmp_path, small_campaign, capsys):
    assert main(["kinematics", str(small_campaign), "--config", str(JUSTIN_CELL), "-o", str(JUSTIN_CELL.parent / "justin.urdf")]) == 2
    assert "URDF" in capsys.readouterr().err


def test_unknown_rung_is_named(small_campaign, capsys):
    assert main(["kinematics", str(small_campaign), "--config", str(JUSTIN_CELL), "--model", "elastic"]) == 2
    assert "--model: expected one of frames, offsets, geometry, joint-elastic, full" in capsys.readouterr().err
