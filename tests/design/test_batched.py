"""The design's batched evaluations give what one configuration at a time gives: the designs of eq 31 and of
the exact model, the criteria of many plans scored together, the feasibility checks, the candidates' draws
and the refinement's steps."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from bayescal.design.criteria import compliance_chain, configuration_designs, criterion_values, nominal_parameters
from bayescal.design.linearisation import DIFFERENCE_STEP, ExactLinearisation, with_parameters
from bayescal.design.optimise import TRIES_PER_CANDIDATE, PlanDesigner
from bayescal.design.refinement import REFINE_STEP_DEG
from bayescal.robot.stiffness import compliance_design
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import DEG


@pytest.fixture(scope="module")
def designer(cell):
    return PlanDesigner(cell, model="linear")


def test_linear_designs_are_eq_31_of_each_configuration(cell, plan):
    wrenches = plan.wrenches(cell)
    design, sigma = configuration_designs(cell, plan.q, wrenches)
    points = list(cell.markers.values())
    for q, wrench, rows, noise in zip(plan.q, wrenches, design, sigma):
        chain = compliance_chain(cell, q[cell.plan_joint])[1] * nominal_parameters(cell)
        expected = np.vstack([compliance_design(cell.robot, q, point, wrench) @ chain for point in points])
        # measured: 5e-16 of the largest entry (Pinocchio's rounding against the stacked arrays')
        np.testing.assert_allclose(rows, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
        np.testing.assert_allclose(noise, np.repeat(np.sqrt(2.0) * cell.tracker.sigma(cell.robot.point_position(q, np.array(points))), 3), rtol=1e-12)


def test_exact_designs_are_the_twins_central_differences(cell, plan):
    wrenches = plan.wrenches(cell)[:4]
    design, _ = ExactLinearisation(cell).wrench_designs(plan.q[:4], wrenches)
    nominal = nominal_parameters(cell)
    for i in range(nominal.size):
        moved = []
        for sign in (1.0, -1.0):
            theta = nominal.copy()
            theta[i] *= 1.0 + sign * DIFFERENCE_STEP
            twin = DigitalTwin(with_parameters(cell, theta))
            moved.append(np.array([np.subtract(*twin.positions_under(q, w)[::-1]).ravel() for q, w in zip(plan.q[:4], wrenches)]))
        column = (moved[0] - moved[1]) / (2.0 * DIFFERENCE_STEP)
        # the differences divide the equilibria's rounding (~1e-16 m) by the step: measured 1.6e-9 of the largest entry
        np.testing.assert_allclose(design[:, :, i], column, rtol=0, atol=1e-7 * np.abs(design).max())


def test_plans_scored_together_score_as_scored_apart(cell, designer):
    rng = np.random.default_rng(0)
    _, _, _, information, _ = designer.candidates(rng, per_angle=2)
    plans = information[rng.integers(len(information), size=(12, 6))].sum(axis=1)
    # hanging loads leave k1 unexcited; the last batch excites it, so the batches hold different parameters
    excited = plans[8:].copy()
    excited[:, 0, 0] += plans[:, 1, 1].max()
    batches = [plans[:5], plans[5:8], excited]
    for criterion in ("test-pose", "compensator", "d-optimal"):
        apart = np.concatenate([criterion_values(cell, batch, criterion) for batch in batches])
        together = criterion_values(cell, np.concatenate(batches), criterion, groups=np.repeat([0, 1, 2], [5, 3, 4]))
        np.testing.assert_array_equal(together, apart)


def test_feasibility_checked_together_is_feasibility_checked_apart(cell, designer):
    rng = np.random.default_rng(1)
    q = rng.uniform(cell.robot.lower - 0.05, cell.robot.upper + 0.05, size=(300, cell.robot.nq))
    force, couple = np.tile([0.0, 0.0, -280.0 * cell.gravity], (len(q), 1)), np.zeros((len(q), 3))
    together = designer.feasibility.violations_under(q, force, couple)
    assert together == [designer.feasibility.violation_under(*row) for row in zip(q, force, couple)]
    kinds = {reason.split(" ")[0] for reason in together if reason}
    assert None in together and {"joint", "marker", "a", "the"} <= kinds


def test_candidates_are_drawn_as_one_draw_after_another(cell, designer):
    q2 = float(designer._grid()[10])
    rng, reference = np.random.default_rng(2), np.random.default_rng(2)
    found = designer._random_configurations(q2, rng, 3, TRIES_PER_CANDIDATE, Counter())
    expected = []
    while len(expected) < 3:
        q = reference.uniform(cell.robot.lower, cell.robot.upper)
        q[cell.plan_joint] = q2
        if designer.feasibility.violation(q, designer.mass) is None:
            expected.append(q)
    np.testing.assert_array_equal(np.array(found), np.array(expected))
    assert rng.random() == reference.random()  # the stream is left where the draws one by one leave it


def _step_as_written(designer, q, step, steps, rng):
    """A refinement step of a hanging-load plan of 5 × 3, drawn from ``rng`` where it is taken, as the search first did."""
    j2 = designer.cell.plan_joint
    first, last = (v * DEG for v in REFINE_STEP_DEG)
    size = first * (last / first) ** (step / (steps - 1))
    proposal = q.copy()
    if rng.random() < 0.3:
        rows = np.arange(3) + 3 * int(rng.integers(5))
        proposal[rows, j2] += rng.normal() * size
        return (proposal, rows) if designer._separated(list(proposal[::3, j2])) else None
    rows = np.array([int(rng.integers(len(q)))])
    proposal[rows[0], [j for j in range(designer.cell.robot.nq) if j != j2]] += rng.normal(size=designer.cell.robot.nq - 1) * size
    return proposal, rows


def test_the_refinement_looking_ahead_takes_the_steps_one_at_a_time(cell, designer):
    start = designer.random_plan(5, 3, np.random.default_rng(3))
    loads = np.tile(designer._down, (len(start.q), 1))
    steps = 60
    drawn = np.random.default_rng(4)
    q, _, score = designer._refine(start.q, loads, 3, "test-pose", designer._moves(drawn, steps, 5, 3))
    # the search as it was written, each step drawn where it is taken and evaluated alone
    rng = np.random.default_rng(4)
    reference = start.q.copy()
    parts = np.array([designer.information(row, designer.mass) for row in reference])
    current = designer._score(parts.sum(axis=0), "test-pose")
    for step in range(steps):
        proposal = _step_as_written(designer, reference, step, steps, rng)
        if proposal is None or any(designer.feasibility.violation(proposal[0][r], designer.mass) for r in proposal[1]):
            continue
        trial = parts.copy()
        for r in proposal[1]:
            trial[r] = designer.information(proposal[0][r], designer.mass)
        value = designer._score(trial.sum(axis=0), "test-pose")
        if value < current:
            reference, parts, current = proposal[0], trial, value
    assert drawn.random() == rng.random()  # the moves drawn ahead leave the stream where the steps drawn in turn do
    np.testing.assert_array_equal(q, reference)
    assert score == pytest.approx(current, rel=1e-12)
