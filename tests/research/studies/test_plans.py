"""Tests of bayescal_studies.studies.plans: the test-pose error a plan leaves over simulated campaigns."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

from pathlib import Path

import numpy as np
import pytest

from bayescal_studies.studies.plans import CampaignModel, compare_plans, simulate_plan


@pytest.fixture(scope="module")
def model(cell, plan):
    return CampaignModel.build(cell, plan, repeats=3)


def test_results_do_not_depend_on_the_number_of_workers(cell, plan, model):
    with ThreadPoolExecutor(1) as one, ThreadPoolExecutor(2) as two:
        a = simulate_plan(cell, plan, campaigns=4, seed=7, executor=one, model=model)
        b = simulate_plan(cell, plan, campaigns=4, seed=7, executor=two, model=model)
    np.testing.assert_array_equal(a["errors"], b["errors"])
    np.testing.assert_array_equal(a["parameter_errors"], b["parameter_errors"])
    assert a["errors"].shape == (4, 3) and not a["excited"][0]


def test_the_linearisation_reproduces_the_noiseless_campaign(cell, plan, model):
    rows = len(plan) * len(cell.markers) * 3
    assert model.design.shape == (rows, 8) and model.nominal_deflections.shape == (rows,)
    # loaded deflections of a 250-280 kg mass are millimetres; the noise tens of micrometres
    assert 1e-3 < np.abs(model.nominal_deflections).max() < 2e-2
    q = plan.q[0]
    points = cell.robot.point_position(q, np.array(list(cell.markers.values())))
    # two readings per deflection, at positions a deflection apart
    np.testing.assert_allclose(model.sigma[:9:3], np.sqrt(2) * cell.tracker.sigma(points), rtol=1e-3)


@pytest.mark.slow
def test_predicted_rho0_agrees_with_the_simulated_error(cell, plan):
    # 300 campaigns: the rms over them is known to about 4 % (delta method)
    scores, widths = compare_plans(cell, {"table III": plan}, campaigns=300, seed=11)
    row = scores.loc["table III"]
    # The truths keep the cell's k1, which the plan does not excite: the data's part of ρ0 is what they leave.
    assert abs(row.simulated_rms_mm - row.criterion_identified_mm) < 3 * row.simulated_rms_se_mm + 0.05 * row.criterion_identified_mm
    identified = widths.loc["table III"].loc[["k2", "k3", "k4", "k5", "k6"]]
    np.testing.assert_allclose(identified.simulated_width_3sd_pct, identified.predicted_width_3sd_pct, rtol=0.2)


def test_the_paired_ratio_standard_error_matches_its_spread():
    from bayescal_studies.studies.plans import _paired_ratio

    rng = np.random.default_rng(0)
    draws = []
    for _ in range(400):
        first = rng.chisquare(3, 200)
        draws.append(_paired_ratio(0.8 * first + 0.3 * rng.chisquare(3, 200), first))
    ratios = np.array([d["rms_ratio_to_first"] for d in draws])
    errors = np.array([d["rms_ratio_se"] for d in draws])
    # 400 draws know the spread to about 4 %
    assert errors.mean() == pytest.approx(ratios.std(ddof=1), rel=0.15)
    assert _paired_ratio(ratios, ratios) == {"rms_ratio_to_first": 1.0, "rms_ratio_se": 0.0}


@pytest.mark.slow
def test_a_hanging_and_a_free_direction_plan_are_scored_as_their_campaigns_realise_them():
    import dataclasses

    from bayescal.cell.config import load_cell
    from bayescal.cell.loading import Loading
    from bayescal.design.optimise import PlanDesigner

    cell = load_cell(Path(__file__).resolve().parents[3] / "data" / "kr270_any_load.toml")
    hanging_cell = dataclasses.replace(cell, loading=Loading(force_max=cell.loading.force_max))
    plans = {
        "hanging": PlanDesigner(hanging_cell, repeats=3, model="linear").optimise(5, 3, "test-pose", rng=0).plan,
        "free": PlanDesigner(cell, repeats=3, model="linear").optimise(5, 3, "test-pose", rng=0).plan,
    }
    # k1's truth from its prior in every campaign of both plans: 4,000 campaigns know the hanging plan's rms,
    # dominated by the log-normal's heavy tail, to about 3 %.
    scores, _ = compare_plans(cell, plans, campaigns=4000, seed=3, vary_all=True, from_prior=("k1",))
    print(scores[["criterion_mm", "criterion_identified_mm", "simulated_rms_mm", "simulated_rms_se_mm"]].to_string())
    for name in plans:
        row = scores.loc[name]
        assert abs(row.simulated_rms_mm / row.criterion_mm - 1) < 0.10, name
    assert scores.loc["free", "criterion_mm"] < scores.loc["hanging", "criterion_mm"]
    assert scores.loc["free", "simulated_rms_mm"] < scores.loc["hanging", "simulated_rms_mm"]
