import dataclasses
import warnings

import numpy as np
import pytest

from bayescal.compensation import compensate_poses, compensate_program, load_calibration
from bayescal.compensation.calibration import GRID_STEP, Calibration
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.compensation.testpose import predict_cell_test_pose, test_pose_program
from bayescal.robot.stiffness import ElasticArm
from bayescal.sampling.gibbs import GibbsSampler
from bayescal_studies.studies.compensation import random_program
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import DEG


@pytest.fixture(scope="module")
def calibrated(cell, plan, tmp_path_factory):
    """A Table III campaign on the twin, calibrated briefly and saved: the results and the posterior file."""
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(5))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=2, n_tune=200, n_draws=600)).fit(campaign, 5)
    path = tmp_path_factory.mktemp("compensate") / "calibration.nc"
    results.save(path)
    return results, path


def _exact_calibration(cell, draws=20) -> Calibration:
    """Every draw at the cell's values: a posterior with no spread."""
    c = cell.compensator
    return Calibration(
        own=np.tile(cell.compliances, (draws, 1)),
        spring=np.tile([c.K_c, c.s0], (draws, 1)),
        geometry=np.tile([c.L, c.a_x, c.a_y, c.phi], (draws, 1)),
        gravity_scale=1.0,
        compensated_joint=cell.compensated_joint,
        unidentified=(),
    )


def test_the_loaded_arm_at_the_compensated_joints_holds_the_unloaded_links(cell):
    # The closed form against the full Newton solve of the loaded equilibrium (dead wrench at the flange).
    program = random_program(cell, 8, np.random.default_rng(0))
    own = np.tile(cell.compliances, (len(program), 1))
    rotations = np.stack([cell.robot.flange_pose(q)[0] for q in program.q])
    wrench = program.flange_wrench(rotations)
    commands, links, failed = compensate_poses(cell.robot, program.q, wrench, own, cell.compensator, cell.compensated_joint)
    assert not failed.any()
    arm = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, compensated_joint=cell.compensated_joint)
    for q, command, target, w in zip(program.q, commands, links, wrench):
        assert np.allclose(q + arm.equilibrium(q, np.zeros(6)), target, atol=1e-11, rtol=0)
        assert np.allclose(command + arm.equilibrium(command, w), target, atol=1e-11, rtol=0)
        assert 1e-5 < np.max(np.abs(command - q)) < 1e-2  # a real correction, of a deflection's size


def test_without_compensator_or_with_another_joint_count_the_same_identity_holds(cell):
    # A five-joint arm is not at hand; the compensator-free case exercises the code without a compensated joint.
    program = random_program(cell, 3, np.random.default_rng(1))
    own = np.tile(cell.compliances, (len(program), 1))
    wrench = program.flange_wrench(np.stack([cell.robot.flange_pose(q)[0] for q in program.q]))
    commands, links, _ = compensate_poses(cell.robot, program.q, wrench, own, None, None)
    arm = ElasticArm.linear(cell.robot, cell.compliances)
    for command, target, w in zip(commands, links, wrench):
        assert np.allclose(command + arm.equilibrium(command, w), target, atol=1e-11, rtol=0)


def test_the_grid_of_the_compensated_joint_matches_eq_8(cell, calibrated):
    calibration = load_calibration(calibrated[1], cell)
    q2 = np.random.default_rng(2).uniform(-130, -20, 3000) * DEG
    assert np.unique(q2).size > (q2.max() - q2.min()) / GRID_STEP  # the grid is used
    interpolated = calibration.compliances(q2)[1](q2)
    exact = calibration.compliances(q2[:5])[1](q2[:5])
    assert np.max(np.abs(interpolated[:5] / exact - 1)) < 1e-5


def test_the_test_pose_of_calibrate_is_the_one_pose_program_of_compensate(cell, calibrated):
    results, path = calibrated
    # calibrate's prediction from the posterior in memory; compensate's from the saved file, on a program
    # holding the test pose and its wrench: one answer, to the last digit.
    prediction = predict_cell_test_pose(results, cell)
    program = test_pose_program(cell, cell.test_q, cell.test_wrench, cell.test_point)
    compensated = compensate_program(program, load_calibration(path, cell), cell)
    for key in ("rms", "q95", "q9973"):
        assert compensated.errors[key][0] == prediction.budget.total[key][0]
        assert compensated.budget.identified[key][0] == prediction.budget.identified[key][0]
    assert np.array_equal(compensated.commands[0], prediction.corrected)
    assert compensated.deflection[0] == pytest.approx(np.linalg.norm(prediction.applied), rel=1e-15)
    # k1 is in the total, with its prior: the identified part is far smaller under hanging loads.
    assert compensated.unidentified == ("k1", "K_c", "s0") or "k1" in compensated.unidentified
    assert prediction.budget.identified["q9973"][0] < 0.1 * prediction.budget.total["q9973"][0]


def test_the_correction_applies_the_median_not_the_mean_of_the_prior(cell, calibrated):
    _, path = calibrated
    calibration = load_calibration(path, cell)
    program = test_pose_program(cell, cell.test_q, cell.test_wrench, cell.test_point)
    median = compensate_program(program, calibration, cell)
    # The same draws with k1 fixed at the cell's value: the correction must not move.
    own = np.array(calibration.own)
    own[:, 0] = cell.compliances[0]
    fixed = compensate_program(program, dataclasses.replace(calibration, own=own), cell)
    assert np.allclose(median.commands, fixed.commands, atol=1e-9, rtol=0)
    # The mean of the log-normal draws, 1.13 times the cell's k1, would have turned the arm by more.
    own[:, 0] = np.mean(calibration.own[:, 0])
    mean = compensate_program(program, dataclasses.replace(calibration, own=own), cell)
    assert np.abs(mean.commands[0, 0] - median.commands[0, 0]) > 1e-3 * np.abs(median.commands[0, 0] - cell.test_q[0])


def test_a_cell_without_compensator_is_compensated_with_constant_compliances(cell):
    bare = dataclasses.replace(cell, compensator=None)
    rng = np.random.default_rng(6)
    own = cell.compliances * np.exp(0.05 * rng.standard_normal((400, 6)))
    calibration = Calibration(own=own, spring=None, geometry=None, gravity_scale=1.0, compensated_joint=None, unidentified=("k1",))
    program = random_program(bare, 20, np.random.default_rng(7))
    compensated = compensate_program(program, calibration, bare)
    assert not compensated.failed.any()
    assert np.all(compensated.errors["rms"] < compensated.errors["q9973"])
    assert np.all((compensated.unidentified_share >= 0) & (compensated.unidentified_share < 1))
    assert np.median(compensated.unidentified_share) > 0.01
    arm = ElasticArm.linear(bare.robot, np.median(own, axis=0))
    wrench = program.flange_wrench(np.stack([bare.robot.flange_pose(q)[0] for q in program.q]))
    for q, command, w in zip(program.q, compensated.commands, wrench):
        assert np.allclose(command + arm.equilibrium(command, w), q + arm.equilibrium(q, np.zeros(6)), atol=1e-11, rtol=0)
