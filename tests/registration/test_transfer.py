"""Moving tracker-frame campaigns and arcs into a registered frame (bayescal.registration.transfer)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bayescal.cell.campaign import write_campaign
from bayescal.errors import InputError
from bayescal.geometry.arcs import read_arc_points
from bayescal.inference.equations import deflection_noise
from bayescal.registration import Frame, read_sweeps, register
from bayescal.registration.transfer import added_covariance, arcs_to_frame, campaign_to_frame, read_registered_campaign
from bayescal.twin.simulator import DigitalTwin
from bayescal.twin.sweeps import TrackerPlacement, simulate_sweeps
from bayescal.units import DEG, UM
from tests.conftest import DATA

HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]
TURN = 5.4 * DEG


def _frame(rotation_sd: float, translation_sd: float = 0.0, rotation=None) -> Frame:
    R = np.eye(3) if rotation is None else rotation
    return Frame("base", R, np.array([1.0, 2.0, 0.5]), np.diag(rotation_sd**2 * np.ones(3)),
                 np.diag(translation_sd**2 * np.ones(3)), "")


def test_added_covariance_matches_turns_drawn_at_random():
    # Rotations drawn from the frame's Gaussian, applied by scipy, not by the first-order formula under test.
    rng = np.random.default_rng(3)
    frame = Frame("base", Rotation.from_rotvec([0.3, -0.2, 1.0]).as_matrix(), np.zeros(3),
                  np.diag([1.0, 4.0, 9.0]) * 1e-8, np.zeros((3, 3)), "")
    v = np.array([[2.0, 0.5, -1.0]])
    turns = Rotation.from_rotvec(rng.multivariate_normal(np.zeros(3), frame.rotation_cov, size=20000)).as_matrix()
    # p_tracker = R_true p_true: the same tracker vector read through the estimated frame and the true ones.
    tracker_vector = frame.rotation @ v[0]
    true = np.einsum("kji,kj->ki", turns @ frame.rotation, np.broadcast_to(tracker_vector, (len(turns), 3)))
    empirical = np.cov(true.T)
    predicted = added_covariance(v, frame)[0]
    assert np.allclose(empirical, predicted, atol=0.05 * np.abs(predicted).max())


def test_added_covariance_is_sd_times_lever_plus_translation():
    cov = added_covariance(np.array([[2.0, 0.0, 0.0]]), _frame(1e-4, 3e-5), translation=True)[0]
    assert np.allclose(np.diag(cov), [0.0 + 9e-10, 4e-8 + 9e-10, 4e-8 + 9e-10])


def test_campaign_moved_back_into_the_base_frame_with_its_tracker(cell, plan):
    rng = np.random.default_rng(11)
    campaign = DigitalTwin(cell).simulate(plan, 1, rng)
    placement = TrackerPlacement(Rotation.from_rotvec([0.0, 0.0, TURN]).as_matrix(), cell.tracker.position)
    tracker = replace(campaign, p0=placement.to_tracker(campaign.p0), p1=placement.to_tracker(campaign.p1))
    exact = Frame("base", placement.rotation.T, placement.to_tracker(np.zeros((1, 3)))[0], np.diag([1e-8] * 3), np.zeros((3, 3)), "")
    transfer, moved = campaign_to_frame(tracker, exact, cell)
    assert np.allclose(transfer.campaign.p0, campaign.p0, atol=1e-12) and np.allclose(transfer.campaign.p1, campaign.p1, atol=1e-12)
    assert np.allclose(moved.tracker.position, cell.tracker.position, atol=1e-12)
    # The added variance reaches the equations' noise: 0.1 mrad on a mm-scale deflection adds a fraction of a μm.
    added = transfer.campaign.added_variance
    assert np.all(added > 0) and np.sqrt(added.max()) < 1 * UM
    with_added = deflection_noise(moved.tracker, transfer.campaign)
    without = deflection_noise(cell.tracker, campaign)
    assert np.allclose(with_added**2 - without**2, added, rtol=1e-6, atol=1e-18)


def test_registered_campaign_file_is_within_a_micrometre_of_the_base_frame(cell, plan, tmp_path):
    rng = np.random.default_rng(5)
    axis = rng.normal(size=3)
    placement = TrackerPlacement(Rotation.from_rotvec(TURN * axis / np.linalg.norm(axis)).as_matrix(), cell.tracker.position)
    campaign = DigitalTwin(cell).simulate(plan, 1, rng)
    write_campaign(replace(campaign, p0=placement.to_tracker(campaign.p0), p1=placement.to_tracker(campaign.p1)), tmp_path / "c.csv")
    simulate_sweeps(cell, placement, rng, home_deg=HOME).to_csv(tmp_path / "s.csv", index=False)
    register(read_sweeps(tmp_path / "s.csv"), cell, rng=0, draws=200).save(tmp_path / "reg.json")
    before = (tmp_path / "c.csv").read_bytes()
    transfer, _ = read_registered_campaign(tmp_path / "c.csv", cell, tmp_path / "reg.json")
    assert (tmp_path / "c.csv").read_bytes() == before
    error = np.linalg.norm(transfer.campaign.displacement - campaign.displacement, axis=1)
    unregistered = np.linalg.norm(campaign.displacement @ placement.rotation - campaign.displacement, axis=1)
    # The file rounds positions to 10 nm; the registration's turn error is a fraction of a mrad.
    assert error.max() < 2 * UM and unregistered.max() > 300 * UM
    sd = np.sqrt(np.trace(transfer.deflection_cov, axis1=1, axis2=2))
    assert np.all(error < 5 * sd + 0.05 * UM)


def test_arcs_moved_into_the_paper_frame_need_z(tmp_path):
    points = read_arc_points(DATA / "table1_geometry.csv")
    with pytest.raises(InputError, match="z_mm"):
        arcs_to_frame(points, _frame(1e-4))
    turn = Rotation.from_rotvec([0.2, -0.4, 1.3]).as_matrix()
    frame = Frame("paper", turn, np.array([1.5, -2.0, 0.3]), np.diag([1e-8] * 3), np.diag([1e-10] * 3), "")
    xyz = np.column_stack([points.xyz, np.full(len(points.xyz), 0.05)])
    tracker = replace(points, xyz=xyz @ turn.T + frame.translation)
    moved = arcs_to_frame(tracker, frame)
    assert np.allclose(moved.points.xyz, xyz, atol=1e-12)
    sd = np.sqrt(np.trace(moved.position_cov, axis1=1, axis2=2) / 3)
    lever = np.linalg.norm(xyz, axis=1)
    assert np.allclose(sd, np.sqrt((2 * 1e-8 * lever**2 + 3e-10) / 3), rtol=0.35)
    assert moved.diagnostics()["sd_added_max_um"] > 0
