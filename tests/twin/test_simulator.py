"""Tests of bayescal.twin.simulator: simulated campaigns and their noise."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bayescal.twin.effects import parse_effect
from bayescal.robot.stiffness import ElasticArm, compliance_design
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def silent(cell):
    return replace(cell, tracker=replace(cell.tracker, factor=0.0))


def test_table_iii_campaign_has_405_equations(cell, plan):
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    assert len(campaign) == 135 and campaign.n_equations == 405
    assert list(campaign.config[:9]) == [1] * 9 and list(campaign.repeat[:9]) == [1, 1, 1, 2, 2, 2, 3, 3, 3]
    assert list(campaign.marker[:3]) == ["M1", "M2", "M3"]
    np.testing.assert_allclose(campaign.q[::9], plan.q)
    np.testing.assert_allclose(campaign.wrench[0], cell.load_wrench(plan.q[0], 250.0))
    again = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    np.testing.assert_array_equal(campaign.p1, again.p1)
    other = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(2))
    assert not np.array_equal(campaign.p1, other.p1)


def test_positions_come_from_the_nonlinear_equilibrium(cell, plan):
    twin = DigitalTwin(cell)
    q, mass = plan.q[4], 265.0
    unloaded, loaded = twin.positions(q, mass)
    points = np.array(list(cell.markers.values()))
    theta0 = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, load_point=cell.load_point, compensated_joint=cell.compensated_joint).equilibrium(q, np.zeros(6))
    np.testing.assert_allclose(unloaded, cell.robot.point_position(q + theta0, points), atol=1e-12)
    # gravity sags the unloaded arm: it is not at the nominal pose
    assert np.abs(unloaded - cell.robot.point_position(q, points)).max() > 1e-4
    # and the loaded deflection is the linear model's to within a few per cent
    wrench = cell.load_wrench(q, mass)
    k = cell.compliances.copy()
    k[1] = 1 / (1 / k[1] + cell.compensator.stiffness(q[1]))
    linear = np.array([compliance_design(cell.robot, q, p, wrench) @ k for p in points])
    deflection = loaded - unloaded
    assert np.linalg.norm(deflection - linear) < 0.03 * np.linalg.norm(linear)
    assert np.linalg.norm(deflection - linear) > 1e-7


def test_noise_between_repeats_matches_the_tracker_model(cell, plan):
    repeats = 12
    campaign = DigitalTwin(cell).simulate(plan, repeats, np.random.default_rng(3))
    shape = (len(plan), repeats, len(cell.markers), 3)
    displacement = campaign.displacement.reshape(shape)
    spread = displacement - displacement.mean(axis=1, keepdims=True)
    sigma = np.sqrt(2) * cell.tracker.sigma(campaign.p0).reshape(shape[:3])
    normalised = spread / sigma[..., np.newaxis] * np.sqrt(repeats / (repeats - 1))
    assert normalised.std() == pytest.approx(1.0, abs=0.05)


def test_effects_change_the_deflections_as_documented(silent, plan):
    rng = np.random.default_rng(0)
    base = DigitalTwin(silent).simulate(plan, 1, rng).displacement
    def with_effect(text):
        return DigitalTwin(silent, [parse_effect(text)]).simulate(plan, 1, np.random.default_rng(0)).displacement
    # a stiffening joint deflects less, a compliant link more
    assert np.linalg.norm(with_effect("nonlinear_stiffness")) < 0.97 * np.linalg.norm(base)
    assert np.linalg.norm(with_effect("link_compliance")) > 1.01 * np.linalg.norm(base)
    # removing the compensator changes the deflections by micrometres only (K_c a L η ≪ K_θ2^0)
    change = np.abs(with_effect("compensator=0") - base).max()
    assert 1e-7 < change < 3e-5
    np.testing.assert_array_equal(with_effect("compensator=1"), base)
    np.testing.assert_array_equal(with_effect("link_compliance=0"), base)
    outliers = np.linalg.norm(with_effect("outliers=0.05") - base, axis=1)
    assert 0 < np.mean(outliers > 4e-4) < 0.2


def test_repeated_or_impossible_requests(cell, plan):
    with pytest.raises(ValueError, match="more than once"):
        DigitalTwin(cell, [parse_effect("backlash"), parse_effect("backlash=0.01")])
    with pytest.raises(ValueError, match="at least 1 repeat"):
        DigitalTwin(cell).simulate(plan, 0, np.random.default_rng(0))


def test_a_force_in_any_direction_deflects_as_the_linear_model_says(data_dir):
    # eq 31 (compliance_design) is written apart from the twin's equilibrium solver
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import Plan

    cell = load_cell(data_dir / "kr270_any_load.toml")
    silent = replace(cell, tracker=replace(cell.tracker, factor=0.0))
    q = np.radians([[20.0, -60.0, 40.0, 10.0, 30.0, -20.0]] * 2)
    force = np.array([[2000.0, -1500.0, 800.0], [0.0, 0.0, -2700.0]])
    couple = np.array([[0.0, 0.0, 400.0], [0.0, 0.0, 0.0]])
    plan = Plan(q=q, load_kg=None, lines=np.zeros(2, dtype=int), force=force, couple=couple)
    campaign = DigitalTwin(silent).simulate(plan, 1, np.random.default_rng(0))
    points = np.array(list(cell.markers.values()))
    k = cell.compliances.copy()
    k[1] = 1 / (1 / k[1] + cell.compensator.stiffness(q[0, 1]))
    for row in range(2):
        wrench = cell.wrench(q[row], force[row], couple[row])
        np.testing.assert_allclose(campaign.wrench[3 * row], wrench)
        linear = np.array([compliance_design(cell.robot, q[row], p, wrench) @ k for p in points])
        deflection = campaign.displacement[3 * row : 3 * row + 3]
        assert np.linalg.norm(deflection - linear) < 0.03 * np.linalg.norm(linear)
    # the horizontal force and the vertical couple turn A1, which a hanging mass never does
    sideways = DigitalTwin(replace(silent, compliances=cell.compliances * [2, 1, 1, 1, 1, 1])).simulate(plan, 1, np.random.default_rng(0))
    moved = np.abs(sideways.displacement - campaign.displacement).reshape(2, -1).max(axis=1)
    assert moved[0] > 1e-5 and moved[1] < 1e-9


@pytest.mark.parametrize("effects", [(), ("link_compliance",), ("outliers=0.05",)])
def test_the_batched_campaign_reads_what_one_configuration_at_a_time_reads(cell, plan, effects):
    twin = DigitalTwin(cell, [parse_effect(text) for text in effects])
    campaign = twin.simulate(plan, 2, np.random.default_rng(7))
    rng = np.random.default_rng(7)
    p0, p1 = [], []
    for q, wrench in zip(plan.q, plan.wrenches(cell)):
        unloaded, loaded = twin.positions_under(q, wrench)
        for _ in range(2):
            readings = []
            for exact in (unloaded, loaded):
                measured = cell.tracker.measure(exact, rng)
                for effect in twin.effects:
                    measured = effect.corrupt(measured, rng)
                readings.append(measured)
            p0.append(readings[0])
            p1.append(readings[1])
    # measured: 1.8e-15 m apart (the stacked arrays' rounding against Pinocchio's)
    np.testing.assert_allclose(campaign.p0, np.vstack(p0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(campaign.p1, np.vstack(p1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(campaign.wrench[::6], plan.wrenches(cell), rtol=0, atol=1e-9)
