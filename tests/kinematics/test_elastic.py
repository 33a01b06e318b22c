"""The kinematic calibration with an elastostatic model's deflection (the KR-270 and its spring compensator)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan
from bayescal.errors import InputError
from bayescal.kinematics.cell import load_points_cell
from bayescal.kinematics.elastic import ArmDeflection, ElasticKinematicCalibration
from bayescal.kinematics.from_campaign import campaign_positions
from bayescal.twin.kinematic_errors import KinematicErrors, with_kinematic_errors
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def cell(data_dir):
    return load_cell(data_dir / "kr270.toml")


@pytest.fixture(scope="module")
def points(data_dir):
    return load_points_cell(data_dir / "robots" / "kr270_points.toml")


def _deflection(cell, points):
    return ArmDeflection(cell, points, compliances=cell.compliances, compensator=cell.compensator)


def test_the_deflection_is_the_twins_sag_and_its_load(cell, points):
    twin, deflection = DigitalTwin(cell), _deflection(cell, points)
    q = np.array([[0.3, -0.8, 0.6, 0.2, -0.4, 0.5], [-1.0, -1.9, 1.2, -0.5, 0.9, -2.0]])
    rigid = np.array([[cell.robot.point_position(qi, cell.markers[n]) for n in points.marker_names] for qi in q])
    exact = np.array([twin.positions(qi, 265.0) for qi in q])  # (N, 2, M, 3)
    wrenches = np.array([cell.load_wrench(qi, 265.0) for qi in q])
    assert np.abs(deflection(q) - (exact[:, 0] - rigid)).max() < 1e-10
    assert np.abs(deflection(q, wrenches) - (exact[:, 1] - rigid)).max() < 1e-10
    assert np.abs(exact[:, 0] - rigid).max() > 0.5e-3  # the sag matters at the tracker's tens of microns


def test_a_marker_the_elastostatic_cell_lacks_is_named(cell, points):
    with pytest.raises(InputError, match="marker 'M1'"):
        _deflection(dataclasses.replace(cell, markers={"other": np.zeros(3)}), points)


def test_table_iii_absolute_positions_identify_the_spring_and_the_errors(cell, points, data_dir):
    """Table III's 15 configurations, unloaded, with kinematic errors: the spring loaded-minus-unloaded cannot see."""
    errors = KinematicErrors.draw(cell.robot, np.random.default_rng(5))
    twin = DigitalTwin(with_kinematic_errors(cell, errors))
    campaign = twin.simulate(read_plan(data_dir / "table3_plan.csv", cell.robot), 1, np.random.default_rng(6))
    positions, *_ = campaign_positions(campaign, points)
    # The elastostatic medians a loaded-minus-unloaded campaign leaves: the compliances right, the spring 60 % off.
    start = ArmDeflection(cell, points, compliances=cell.compliances, compensator=cell.compensator.with_spring(230e3, 0.55))
    fit = ElasticKinematicCalibration(points, start, {"K_c": 100e3, "K_c_s0": 50e3, "gravity_scale": 0.5}).fit(positions)
    spring = fit.spring()
    for (mean, sd), truth in ((spring["K_c"], 144.0), (spring["s0"], 458.0), (tuple(fit.summary().loc["A5.ty", ["mean", "sd"]]),
                                                                               errors.deltas[4, 1] * 1e3)):
        assert abs(mean - truth) < 3 * sd, truth
    assert spring["K_c"][1] < 5.0  # N/mm: the loaded-minus-unloaded campaign leaves ±100
    assert fit.kinematic.model_sd < 20e-6  # m; measured 10.8 μm on top of the tracker's 32-44


@pytest.fixture(scope="module")
def saved(tmp_path_factory, data_dir):
    """A twin campaign with kinematic errors, calibrated, then fitted with ``--elastic`` and saved, on a copy of the cell."""
    from bayescal.cli import main

    folder = tmp_path_factory.mktemp("elasticio")
    text = (data_dir / "kr270.toml").read_text()
    text = text.replace('"robots/kr270.urdf"', f'"{(data_dir / "robots" / "kr270.urdf").as_posix()}"')
    text = text.replace('"paper_reference.csv"', f'"{(data_dir / "paper_reference.csv").as_posix()}"')
    files = {name: str(folder / name) for name in ("cell.toml", "campaign.csv", "positions.csv", "elastic.nc", "cal.nc")}
    Path(files["cell.toml"]).write_text(text)
    points = str(data_dir / "robots" / "kr270_points.toml")
    assert main(["simulate", "--plan", str(data_dir / "table3_plan.csv"), "--config", files["cell.toml"], "--seed", "3",
                 "--kinematic-errors", "1", "-o", files["campaign.csv"], "--positions", files["positions.csv"]]) == 0
    assert main(["calibrate", files["campaign.csv"], "--config", files["cell.toml"], "--posterior", files["elastic.nc"]]) == 0
    assert main(["kinematics", files["positions.csv"], "--config", points, "--elastic", files["elastic.nc"],
                 "--elastic-config", files["cell.toml"], "-o", files["cal.nc"]]) == 0
    return files | {"points": points}


def test_predict_from_a_saved_elastic_calibration_is_the_fitted_ones(saved, tmp_path, capsys):
    from bayescal.cli import main
    from bayescal.compensation.calibration import load_calibration
    from bayescal.kinematics import load_kinematic_calibration, read_positions

    points = load_points_cell(saved["points"])
    elastic_cell = load_cell(saved["cell.toml"])
    positions = read_positions(saved["positions.csv"], points)
    fitted = ElasticKinematicCalibration.from_calibration(elastic_cell, points, load_calibration(saved["elastic.nc"], elastic_cell)
                                                          ).fit(positions)
    loaded = load_kinematic_calibration(saved["cal.nc"], points)
    mean, covariance = fitted.predict(positions.joints)
    again, again_covariance = loaded.predict(positions.joints)
    assert np.abs(again - mean).max() < 1e-9  # m
    sd, again_sd = (np.sqrt(np.diagonal(c, axis1=-2, axis2=-1)) for c in (covariance, again_covariance))
    assert np.abs(again_sd - sd).max() < 1e-9
    assert np.abs(loaded.deflection(positions.joints) - fitted.deflection(positions.joints)).max() < 1e-9
    asked = tmp_path / "asked.csv"
    pd.read_csv(saved["positions.csv"], comment="#").drop(columns=["x_mm", "y_mm", "z_mm"]).to_csv(asked, index=False)
    out = tmp_path / "predicted.csv"
    assert main(["predict", str(asked), "--calibration", saved["cal.nc"], "--config", saved["points"], "-o", str(out)]) == 0
    written = pd.read_csv(out)
    # The file's rows are the configurations' markers in order; written to 1e-4 mm.
    assert np.abs(written[["x_mm", "y_mm", "z_mm"]].to_numpy() - mean.reshape(-1, 3) * 1e3).max() < 0.6e-4
    assert np.abs(written[["x_sd_mm", "y_sd_mm", "z_sd_mm"]].to_numpy() - sd.reshape(-1, 3) * 1e3).max() < 0.6e-4


@pytest.mark.parametrize("change, expected", [
    (lambda path: path.write_text(path.read_text() + "\n# edited\n"), "has changed since"),
    (lambda path: path.rename(path.with_suffix(".moved")), "is missing"),
])
def test_a_changed_or_missing_elastostatic_cell_is_named(saved, tmp_path, capsys, change, expected):
    from bayescal.cli import main

    cell = tmp_path / "cell.toml"
    cell.write_bytes(Path(saved["cell.toml"]).read_bytes())
    calibration, out = tmp_path / "cal.nc", tmp_path / "predicted.csv"
    assert main(["kinematics", saved["positions.csv"], "--config", saved["points"], "--elastic", saved["elastic.nc"],
                 "--elastic-config", str(cell), "-o", str(calibration)]) == 0
    capsys.readouterr()
    change(cell)
    assert main(["predict", saved["positions.csv"], "--calibration", str(calibration), "--config", saved["points"], "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and str(cell) in err and len(err.splitlines()) == 1 and not out.exists()


def test_a_loads_predictive_covariance_carries_the_compliances_posterior(saved):
    """The loaded prediction's covariance adds the compliances' spread: the linearised term equals the spread of the
    load's deflection over the elastostatic posterior's draws, and a saved calibration predicts the same."""
    from bayescal.compensation.calibration import load_calibration
    from bayescal.kinematics import load_kinematic_calibration
    from bayescal.cell.campaign import read_campaign

    points, elastic_cell = load_points_cell(saved["points"]), load_cell(saved["cell.toml"])
    calibration = load_calibration(saved["elastic.nc"], elastic_cell)
    positions, *_ = campaign_positions(read_campaign(saved["campaign.csv"], cell=elastic_cell), points)
    fitted = ElasticKinematicCalibration.from_calibration(elastic_cell, points, calibration).fit(positions)
    observed, wrenches, load_points = campaign_positions(read_campaign(saved["campaign.csv"], cell=elastic_cell), points, loaded=True)
    mean, covariance = fitted.predict(observed.joints, wrenches, load_points)
    _, without = dataclasses.replace(fitted, compliance_covariance=None).predict(observed.joints, wrenches, load_points)
    added = covariance - without

    base = fitted.deflection
    draws = []
    for own in calibration.own[:: max(1, calibration.n_draws // 400)]:
        moved = ArmDeflection(base.cell, points, compliances=own, compensator=base.compensator, gravity_scale=base.gravity_scale)
        draws.append(moved(observed.joints, wrenches, load_points) - moved(observed.joints))
    spread = np.einsum("snma,snmb->nmab", *(2 * [np.asarray(draws) - np.mean(draws, axis=0)])) / (len(draws) - 1)
    variances = np.diagonal(added, axis1=-2, axis2=-1)
    largest = variances > 0.1 * variances.max()
    ratio = variances[largest] / np.diagonal(spread, axis1=-2, axis2=-1)[largest]
    assert np.all(np.abs(ratio - 1.0) < 0.25), ratio  # sampling error of ~400 draws and the linearisation
    assert np.sqrt(variances.max()) > 5e-6  # m: worth carrying beside the tracker's tens of microns

    again, again_covariance = load_kinematic_calibration(saved["cal.nc"], points).predict(observed.joints, wrenches, load_points)
    assert np.abs(again - mean).max() < 1e-9 and np.abs(again_covariance - covariance).max() < 1e-15
