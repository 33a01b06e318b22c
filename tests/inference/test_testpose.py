import warnings
from pathlib import Path

import numpy as np
import pytest

from bayescal.sampling.gibbs import GibbsSampler
from bayescal.cell.config import load_cell
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import exact_deflections
from bayescal.cell.plan import read_plan
from bayescal.inference.testpose import predict_cell_test_pose, predict_test_pose
from bayescal.twin.simulator import DigitalTwin

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def setup():
    cell = load_cell(DATA / "kr270.toml")
    plan = read_plan(DATA / "table3_plan.csv", cell.robot)
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=4, n_tune=300, n_draws=400)).fit(campaign, 3)
    return cell, results


def test_rho0_from_covariance_agrees_with_the_draws(setup):
    cell, results = setup
    prediction = predict_cell_test_pose(results, cell)
    block = prediction.to_json()
    error = block["residual_error_mm"]
    assert error["rms"] == pytest.approx(error["rho0_from_covariance"], rel=0.05)
    assert error["rms"] < error["q95"] < error["q99.73"]
    assert block["assumed"]["k1"]["value"] == pytest.approx(0.30)


def test_prediction_covers_the_true_deflection(setup):
    cell, results = setup
    prediction = predict_cell_test_pose(results, cell)
    true = exact_deflections(
        cell.robot,
        cell.test_q,
        cell.test_wrench,
        cell.compliances,
        cell.compensator,
        points_in_flange=np.atleast_2d(cell.test_point),
        load_point=cell.test_point,
        compensated_joint=cell.compensated_joint,
    )[0]
    block = prediction.to_json()["deflection_mm"]
    for i, axis in enumerate("xyz"):
        # k1 is held at its true value here, so the truth must lie inside ±3σ.
        assert block[axis]["lo3"] <= true[i] * 1e3 <= block[axis]["hi3"], axis
    against_truth = predict_cell_test_pose(results, cell, truth=true)
    # An honest posterior misses the truth by about its own spread, not by several times it.
    assert np.sqrt(np.mean(against_truth.errors**2)) < 3 * np.sqrt(np.mean(prediction.errors**2))


def test_unidentified_joint_without_a_nominal_value_is_reported(setup):
    cell, results = setup
    prediction = predict_test_pose(
        results, cell.robot, cell.test_q, cell.test_wrench, cell.test_point, nominal_compensator=cell.compensator
    )
    block = prediction.to_json()
    assert block["available"] is False
    assert "k1" in block["reason"]
