"""``bayescal export``: the calibrated URDF loads in Pinocchio as the cell's robot, carries the compliances, and a
cell pointing at it calibrates as the original."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import bayescal.cli as cli
from bayescal.controllers.urdf import read_compliances


@pytest.fixture
def main(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("export",))
    return cli.main


@pytest.fixture
def exported(main, short_calibration, tmp_path):
    out = tmp_path / "kr270_calibrated.urdf"
    assert main(["export", "--calibration", str(short_calibration["calibration"]), "--config", str(short_calibration["config"]), "-o", str(out)]) == 0
    return out


def test_pinocchio_loads_the_export_with_the_cells_flange_poses(exported, cell):
    model = pin.buildModelFromUrdf(str(exported))
    data = model.createData()
    frame = model.getFrameId(cell.robot.flange)
    rng = np.random.default_rng(0)
    q = rng.uniform(cell.robot.lower, cell.robot.upper, (1000, cell.robot.nq))
    worst = 0.0
    for qi in q:
        pin.framesForwardKinematics(model, data, qi)
        rotation, origin = cell.robot.flange_pose(qi)
        worst = max(worst, np.abs(data.oMf[frame].translation - origin).max(), np.abs(data.oMf[frame].rotation - rotation).max())
    assert worst <= 1e-9


def test_the_compliances_are_the_calibrations_mean_and_sd(exported, cell, short_calibration):
    from bayescal.compensation import load_calibration

    calibration = load_calibration(short_calibration["calibration"], cell)
    read = read_compliances(exported, cell.robot)
    assert list(read) == list(cell.robot.joint_names)
    mean = np.array([read[name]["mean"] for name in cell.robot.joint_names])
    sd = np.array([read[name]["sd"] for name in cell.robot.joint_names])
    assert np.allclose(mean, calibration.own.mean(axis=0), rtol=1e-5, atol=0)
    assert np.allclose(sd, calibration.own.std(axis=0, ddof=1), rtol=1e-5, atol=0)
    assert [not read[name]["identified"] for name in cell.robot.joint_names] == [f"k{j + 1}" in calibration.unidentified for j in range(6)]
    original = open(cell.robot.source, "rb").read()
    assert exported.read_bytes().replace(b' xmlns:bayescal="urn:bayescal:urdf-extension:1"', b"").startswith(original[: original.rindex(b"</robot>")])


def test_a_cell_pointing_at_the_export_calibrates_as_the_original(exported, cell, data_dir, campaign_csv, tmp_path):
    import warnings

    from bayescal.cell.campaign import read_campaign
    from bayescal.cell.config import load_cell
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.sampling.gibbs import GibbsSampler

    text = (data_dir / "kr270.toml").read_text()
    text = text.replace('urdf = "robots/kr270.urdf"', f'urdf = "{exported}"').replace('reference_csv = "paper_reference.csv"', f'reference_csv = "{data_dir / "paper_reference.csv"}"')
    (tmp_path / "calibrated.toml").write_text(text)
    moved = load_cell(tmp_path / "calibrated.toml")
    assert moved.robot.source == str(exported)
    summaries = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for each in (cell, moved):
            model = ElastostaticModel.from_cell(each, sampler=GibbsSampler(n_chains=2, n_tune=50, n_draws=50))
            summaries.append(model.fit(read_campaign(campaign_csv, cell=each), 0).summary())
    assert summaries[0].equals(summaries[1])


def test_an_output_over_the_cells_urdf_is_refused(main, short_calibration, cell, capsys):
    before = open(cell.robot.source, "rb").read()
    assert main(["export", "--calibration", str(short_calibration["calibration"]), "--config", str(short_calibration["config"]), "-o", cell.robot.source]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert open(cell.robot.source, "rb").read() == before


JUSTIN_CELL = __import__("pathlib").Path(__file__).resolve().parents[2] / "data" / "robots" / "justin.toml"


def test_a_kinematic_calibrations_placements_are_the_exported_joint_origins(monkeypatch, tmp_path):
    from bayescal.kinematics import load_points_cell
    from bayescal.kinematics.model import PointModel
    from bayescal.kinematics.results import KinematicResults

    monkeypatch.setattr(cli, "COMMANDS", ("export",))
    justin = load_points_cell(JUSTIN_CELL)
    model = PointModel(justin, "full")
    # A calibration whose every parameter sits a prior sd or so from its prior mean: placements visibly corrected.
    mean = model.mean + model.sd * np.random.default_rng(1).normal(size=model.size)
    KinematicResults(model=model, mean=mean, covariance=np.diag(model.sd**2) * 0.01, information=None, model_sd=1e-4,
                     residuals=None, positions=None).save(tmp_path / "kinematics.nc")
    out = tmp_path / "justin_calibrated.urdf"
    assert cli.main(["export", "--calibration", str(tmp_path / "kinematics.nc"), "--config", str(JUSTIN_CELL), "-o", str(out)]) == 0
    exported = pin.buildModelFromUrdf(str(out))
    data = exported.createData()
    tree = justin.tree
    corrections = {j: pin.exp6(delta) for j, delta in model._corrections(mean).items()}
    assert corrections
    rng = np.random.default_rng(0)
    q = rng.uniform(tree.model.lowerPositionLimit, tree.model.upperPositionLimit, (1000, tree.model.nq))
    frames = tree.frames(q, corrections)
    worst = 0.0
    for i, qi in enumerate(q):
        pin.forwardKinematics(exported, data, qi)
        origins = np.array([data.oMi[j].translation for j in range(1, exported.njoints)])
        worst = max(worst, np.abs(origins - frames.origin[i, 1:]).max())
    assert worst <= 1e-9
    read = read_compliances(out, type("Chain", (), {"joint_names": tuple(tree.names[j] for j in model.elastic), "prismatic": np.zeros(len(model.elastic), bool)})())
    assert set(read) == {tree.names[j] for j in model.elastic}
