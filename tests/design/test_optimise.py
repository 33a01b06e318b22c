"""Tests of bayescal.design.optimise: the exchange and refinement of calibration plans."""

from __future__ import annotations

import json
import math
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from bayescal import forked
from bayescal.cell.plan import read_plan
from bayescal.design.optimise import PlanDesigner
from bayescal.errors import InputError

SMALL = {"starts": 1, "refine_steps": 30, "candidates_per_angle": 3}
"""A quick optimisation: enough to test the algorithm's contract, not its optimum."""


@pytest.fixture(scope="module")
def designer(cell):
    return PlanDesigner(cell, model="linear")


@pytest.fixture(scope="module")
def design(designer):
    return designer.optimise(4, 2, "test-pose", rng=5, **SMALL)


def test_the_plan_has_the_requested_structure_and_is_feasible(design, designer):
    q2 = design.plan.q[:, 1].reshape(4, 2)
    assert np.all(q2 == q2[:, :1])  # each group shares its q2
    assert np.min(np.diff(np.sort(q2[:, 0]))) >= designer.space.min_separation - 1e-12
    assert designer.violations(design.plan) == []
    np.testing.assert_array_equal(design.plan.load_kg, 280.0)  # the heaviest load of the range


def test_the_same_seed_gives_the_same_plan(design, designer):
    again = designer.optimise(4, 2, "test-pose", rng=5, **SMALL)
    np.testing.assert_array_equal(again.plan.q, design.plan.q)


def test_the_starts_run_in_forked_processes_give_the_plan_of_one_process(designer, monkeypatch):
    options = SMALL | {"starts": 3}
    alone = designer.optimise(4, 2, "test-pose", rng=6, **options)
    monkeypatch.setattr(forked, "_single_threaded", lambda: True)
    forks = []
    monkeypatch.setattr(forked, "ProcessPoolExecutor", lambda *a, **k: forks.append(a) or ProcessPoolExecutor(*a, **k))
    shared = designer.optimise(4, 2, "test-pose", rng=6, workers=2, **options)
    assert forks == [(2,)]
    np.testing.assert_array_equal(shared.plan.q, alone.plan.q)
    assert shared.starts == alone.starts and shared.linear.rho0 == alone.linear.rho0


def test_the_optimised_plan_beats_random_feasible_plans(design, designer):
    rng = np.random.default_rng(2)
    randoms = [designer.evaluate(designer.random_plan(4, 2, rng), "linear").rho0 for _ in range(5)]
    assert design.linear.rho0 < min(randoms)


def test_json_and_saved_plan(design, designer, tmp_path, cell):
    payload = design.to_json()
    assert payload["criterion"] == pytest.approx(design.prediction.rho0 / 1e-3)
    assert payload["optimised_for"] == "test-pose" and payload["configurations"] == 8 and len(payload["q2_deg"]) == 4
    assert set(payload["parameters"]) == {"k1", "k2", "k3", "k4", "k5", "k6", "K_c", "s0"}
    path = tmp_path / "plan.csv"
    design.save(path)
    again = read_plan(path, cell.robot)
    assert designer.evaluate(again).rho0 == pytest.approx(design.prediction.rho0, rel=1e-3)
    assert list(design.summary().columns) == ["value", "sd", "width_3sd_pct", "table_iv_pct", "unit"]


@pytest.mark.parametrize(
    ("request_", "message"),
    [
        ({"angles": 40}, "do not fit in the joint range"),
        ({"angles": 2}, "at least 3 distinct q2 angles"),
        ({"angles": 2, "criterion": "d-optimal"}, "at least 3 distinct q2 angles"),
        ({"criterion": "a-optimal"}, "unknown criterion"),
        ({"per_angle": 0}, "at least 1 configuration per angle"),
    ],
)
def test_infeasible_requests(designer, request_, message):
    with pytest.raises(InputError, match=message):
        designer.optimise(**({"angles": 5, "per_angle": 3} | request_), rng=0, **SMALL)


def test_table_iii_is_scored_and_its_violations_listed(designer, plan):
    prediction = designer.evaluate(plan, "linear")
    assert math.isfinite(prediction.rho0)
    # its q1 were chosen for the paper's tracker, which is not where the twin's is
    assert len(designer.violations(plan)) > 0


def test_an_assessed_plan_has_the_four_verbs_of_every_result(designer, plan, tmp_path):
    evaluation = designer.assess(plan, "table3_plan.csv")
    assert evaluation.to_json()["criterion"] == pytest.approx(designer.evaluate(plan, "exact").rho0 / 1e-3)
    assert evaluation.to_json()["linear_model"]["criterion"] == pytest.approx(designer.evaluate(plan, "linear").rho0 / 1e-3)
    assert evaluation.diagnostics()["violations"] == designer.violations(plan) and evaluation.diagnostics()["configurations"] == len(plan)
    assert list(evaluation.summary().index) == list(evaluation.to_json()["parameters"])
    evaluation.save(tmp_path / "evaluation.json")
    assert json.loads((tmp_path / "evaluation.json").read_text()) == json.loads(json.dumps(evaluation.to_json()))


def test_a_tracker_that_sees_no_marker_is_refused(cell):
    from dataclasses import replace

    hidden = replace(cell, tracker=replace(cell.tracker, position=np.array([0.0, 0.0, 0.3])))  # inside the base
    with pytest.raises(InputError, match=r"no feasible configuration found in the cell \(most frequent reason: "):
        PlanDesigner(hidden, model="linear").optimise(5, 3, rng=0, **SMALL)


def test_the_progress_note_names_its_unit_and_the_bar_stays_off_a_log(capsys):
    from bayescal.design.progress import Progress, best_text

    assert best_text(1.591e-06, "test-pose") == "best: ρ0 = 1.59 μm"  # ends with the criterion's unit
    assert "%" in best_text(0.25, "compensator")
    bar = Progress(3, "plan", True)  # stderr is captured here, not a terminal
    bar.step("x")
    bar.close()
    assert capsys.readouterr().err == ""


def test_more_configurations_per_angle_than_the_candidates_blames_per_angle_before_any_draw(designer, monkeypatch):
    def no_draw(*args, **kwargs):
        raise AssertionError("candidates drawn before the request was checked")

    monkeypatch.setattr(PlanDesigner, "candidates", no_draw)
    with pytest.raises(InputError) as caught:
        designer.optimise(5, 21, rng=0)
    assert caught.value.source == "per_angle" and "at most 20 configurations per q2 angle" in caught.value.what


def test_equilibria_solved_after_the_steps_give_the_plan_solved_before_them(cell, monkeypatch):
    # A rule of the test's own declares a third of the configurations without a loaded equilibrium: the linear
    # search, which solves the equilibria of the candidates together and those of the refinement's steps after
    # them (taking the steps again where one had none), gives the plan of a search that solves each with the
    # other checks.
    from bayescal.design.constraints import Feasibility
    from bayescal.design.refinement import Refinement

    solve = Feasibility._equilibria

    def some_fail(self, q, force, couple, rows, reasons):
        solve(self, q, force, couple, rows, reasons)
        for qi, row in zip(q, rows):
            if int(abs(qi[4]) * 1e4) % 3 == 0:
                reasons[row] = "no loaded equilibrium (the test's rule)"

    class SolvedFirst(PlanDesigner):
        def _violations(self, q, loads, *, solve=True, poses=None):
            return super()._violations(q, loads, solve=True, poses=poses)

    passes = []
    steps = Refinement._refine_steps
    monkeypatch.setattr(Feasibility, "_equilibria", some_fail)
    monkeypatch.setattr(Refinement, "_refine_steps", lambda self, *args: passes.append(1) or steps(self, *args))
    options = {"starts": 2, "refine_steps": 60, "candidates_per_angle": 6}
    deferred = PlanDesigner(cell, model="linear").optimise(4, 2, "test-pose", rng=4, **options)
    assert len(passes) > 2  # a step took a configuration without equilibrium, and the steps were taken again
    first = SolvedFirst(cell, model="linear").optimise(4, 2, "test-pose", rng=4, **options)
    np.testing.assert_array_equal(deferred.plan.q, first.plan.q)
    assert deferred.starts == first.starts and deferred.candidates == first.candidates
    assert not any(int(abs(q[4]) * 1e4) % 3 == 0 for q in deferred.plan.q)
