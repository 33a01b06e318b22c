import warnings
from pathlib import Path

import numpy as np
import pytest

from bayescal.sampling.gibbs import GibbsSampler
from bayescal.cell.config import load_cell
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import exact_deflections
from bayescal.cell.plan import read_plan
from bayescal.compensation.testpose import predict_cell_test_pose
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


def test_the_budget_counts_what_the_campaign_cannot_identify_and_says_so(setup):
    cell, results = setup
    error = predict_cell_test_pose(results, cell).to_json()["residual_error_mm"]
    assert error["rms"] < error["q95"] < error["q99.73"]
    identified = error["identified_only"]
    assert identified["q99.73"] < error["q99.73"] and "k1" in error["unidentified"] and "k1" in error["includes"]
    assert error["added_by_unidentified_q99.73"] == pytest.approx(error["q99.73"] - identified["q99.73"])
    assert error["priors"]["k1"]["median"] == pytest.approx(0.30) and error["priors"]["k1"]["log_sd"] == 0.5
    # Hanging loads leave k1 to its prior, a factor 0.22-4.5 at ±3σ: it dominates the error at a sideways wrench.
    assert error["unidentified_share_of_mean_square"] > 0.9


def test_the_correction_lands_on_the_true_deflection_within_the_identified_bound(setup):
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
    # The twin's k1 is the cell's value, the one the correction applies: what is left is the identified
    # parameters' error (and eq 31's linearisation), inside their 99.73 % bound.
    miss = np.linalg.norm(prediction.applied - true)
    assert miss < prediction.budget.identified["q9973"][0]
    block = prediction.to_json()["deflection_mm"]
    for i, axis in enumerate("xyz"):
        assert block[axis]["lo3"] <= true[i] * 1e3 <= block[axis]["hi3"], axis
    against = prediction.against(true)
    # An honest posterior misses the truth by about its own spread, not by several times it.
    assert against["rms"] < 3 * np.sqrt(np.mean(prediction.errors**2)) / 1e-3
