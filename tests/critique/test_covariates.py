from dataclasses import replace

import numpy as np
import pytest

from bayescal.critique.covariates import campaign_rows, measured_pose, pose_rows, wrench_at_pose
from bayescal.robot.stiffness import compliance_design
from bayescal.twin.effects import parse_effect
from bayescal.twin.simulator import DigitalTwin


def test_measured_pose_recovers_the_sag_of_the_unloaded_arm(cell, plan):
    # a stiffer compensator spring (x10) sags the arm by up to a degree before the load goes on
    twin = DigitalTwin(cell, [parse_effect("compensator=10")])
    q = plan.q[0]
    sag = twin._deflections(q, np.zeros(6))
    assert np.max(np.abs(sag)) > 0.01
    points = np.array(list(cell.markers.values()))
    unloaded, _ = twin.positions(q, 0.0)
    pose, misfit = measured_pose(cell, q, points, unloaded)
    assert pose == pytest.approx(q + sag, abs=1e-9) and misfit < 1e-9
    # two markers cannot fix the tool's orientation: the commanded pose is kept
    assert np.array_equal(measured_pose(cell, q, points[:2], unloaded[:2])[0], q)
    # markers off the file's places by millimetres: the shape misfit says so
    moved = points + np.array([[0.002, 0.0, 0.0], [0.0, -0.002, 0.0], [0.0, 0.0, 0.002]])
    assert measured_pose(cell, q, moved, unloaded)[1] > 0.5e-3


def test_the_wrench_turns_with_the_sagging_tool(cell, plan, twin_campaign):
    # a x20 spring sags the arm by up to 2 deg: the load's lever on the tool turns with it
    campaign = twin_campaign(["compensator=20"], seed=0, repeats=1)
    rows = campaign_rows(cell, campaign)
    assert np.max(np.abs(rows.q - campaign.q)) > 0.03
    for i in (0, 20, 40):
        expected = cell.load_wrench(rows.q[i], -campaign.wrench[i, 2] / cell.gravity)
        assert rows.wrench[i] == pytest.approx(expected, abs=1e-9)
    # at the commanded pose nothing changes; a couple beyond the load's moment stays as a dead couple
    assert np.array_equal(wrench_at_pose(cell, campaign, campaign.q), campaign.wrench)
    couple = np.array([0.0, 0.0, 0.0, 10.0, -20.0, 30.0])
    with_couple = replace(campaign, wrench=campaign.wrench + couple)
    assert wrench_at_pose(cell, with_couple, rows.q) - rows.wrench == pytest.approx(np.broadcast_to(couple, rows.wrench.shape), abs=1e-9)


def test_rows_carry_eq_31_and_the_measurement_order(cell, twin_campaign):
    campaign = twin_campaign(seed=0)
    rows = campaign_rows(cell, campaign)
    assert len(rows) == len(campaign)
    i = 7
    expected = compliance_design(cell.robot, rows.q[i], rows.point[i], rows.wrench[i])
    assert rows.design[i] == pytest.approx(expected, rel=1e-12)
    assert np.all(np.diff(rows.order[campaign.marker == "M1"]) == 1)
    assert rows.noise.mean() == pytest.approx(1.0)


def test_pose_rows_put_the_tool_point_at_the_test_pose(cell):
    rows = pose_rows(cell, cell.test_q, cell.test_wrench, cell.test_point)
    assert rows.position[0] == pytest.approx(cell.robot.point_position(cell.test_q, cell.test_point))
    assert rows.load_torque[0] == pytest.approx(cell.robot.flange_jacobian(cell.test_q).T @ cell.test_wrench)
