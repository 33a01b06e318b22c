
import numpy as np
import pytest

from bayescal.cell.campaign import Campaign
from bayescal.cell.nests import Nests
from bayescal.cell.tracker import TrackerNoise
from bayescal.registration.nest_drift import fit_nest_drift, motion_matrix

NEST_POINTS = np.array([[2.5, 0.0, 0.0], [-1.25, 2.165, 0.0], [-1.25, -2.165, 0.3]])
TRACKER = np.array([2.0, 3.0, 0.0])
RATE = np.array([0.2e-3, -0.1e-3, 0.05e-3, 2e-8, -1e-8, 3e-8]) / 3600.0
"""A steady drift: translation (m/s) and rotation about the tracker (rad/s)."""


def steady_nests(noise: TrackerNoise, rng=None, visits=13, every=600.0) -> Nests:
    times = (np.arange(visits)[:, None] * every + 20.0 * np.arange(3)).ravel()
    points = np.tile(NEST_POINTS, (visits, 1))
    readings = points + np.einsum("kij,j,k->ki", motion_matrix(points, TRACKER), RATE, times)
    if rng is not None:
        readings = readings + rng.normal(size=readings.shape) * noise.sigma(points)[:, None]
    return Nests(np.tile(np.array(["A", "B", "C"]), visits), times, readings, np.zeros(len(times), int))


def test_a_steady_drift_is_recovered_between_the_nest_readings():
    # noise of a nanometre: the linear interpolation the random walk's mean makes is exact for a steady drift
    exact = TrackerNoise(TRACKER, 1e-9, 0.0, 1.0)
    track = fit_nest_drift(steady_nests(exact), exact)
    times = np.array([333.0, 3456.0, 7000.0])
    points = np.array([[1.6, 0.4, 1.1], [0.5, -0.5, 0.8], [2.0, 1.0, 1.5]])
    planted = np.einsum("kij,j,k->ki", motion_matrix(points, TRACKER), RATE, times - track.knots[0])
    assert np.allclose(track.motion(points, times)[0], planted, atol=1e-6)
    assert np.allclose(track.frame(track.knots[:1]), 0.0)


def test_the_drift_is_within_its_uncertainty_at_readings_and_in_deflections(cell):
    rng = np.random.default_rng(5)
    track = fit_nest_drift(steady_nests(cell.tracker, rng), cell.tracker)
    points = np.array([[1.5, 0.5, 1.2]] * 40)
    times = np.linspace(100.0, 7100.0, 40)
    mean, cov = track.motion(points, times)
    truth = np.einsum("kij,j,k->ki", motion_matrix(points, TRACKER), RATE, times - track.knots[0])
    z = (mean - truth) / np.sqrt(np.einsum("kii->ki", cov))
    assert np.all(np.abs(z) < 3.0)
    # between nest readings the bridge adds variance; at a nest reading's time it does not
    _, at_knot = track.motion(points[:1], track.knots[5:6])
    _, between = track.motion(points[:1], track.knots[5:6] + 290.0)
    assert np.trace(between[0]) > np.trace(at_knot[0])


def test_removing_the_drift_takes_it_out_of_both_readings_and_adds_its_variance(cell):
    rng = np.random.default_rng(6)
    track = fit_nest_drift(steady_nests(cell.tracker, rng), cell.tracker)
    n = 6
    times = np.stack([np.linspace(200.0, 6000.0, n), np.linspace(680.0, 6480.0, n)], axis=1)
    p0 = np.tile([1.6, 0.4, 1.1], (n, 1))
    p1 = p0 + [0.0, 0.0, -1e-3]
    campaign = Campaign(np.arange(n), np.ones(n, int), np.array(["P"] * n), np.zeros((n, 6)), np.zeros((n, 6)),
                        p0, p1, np.zeros(n, int), times=times, added_variance=np.full(n, 1e-12))
    removed = track.remove(campaign)
    assert np.allclose(removed.p0, p0 - track.motion(p0, times[:, 0])[0])
    assert np.allclose(removed.p1, p1 - track.motion(p1, times[:, 1])[0])
    mean, cov = track.deflection(campaign)
    assert np.allclose(removed.displacement, campaign.displacement - mean)
    assert removed.added_variance == pytest.approx(1e-12 + np.linalg.eigvalsh(cov)[:, -1])
    summary = track.to_json(campaign)
    assert summary["nests"] == 3 and summary["deflection_removed_rms_um"] > 0


def test_nests_measure_the_independent_generators_drift_within_three_sd(cell, plan):
    from bayescal.twin.independent.generator import IndependentGenerator

    within = []
    for seed in range(3):
        campaign, truth = IndependentGenerator(cell, np.random.default_rng(seed)).simulate(plan, 3, "thermal_drift", 1.0, nests=True)
        track = fit_nest_drift(truth.nests, cell.tracker)
        drift = truth.world.drift
        start = np.full(len(campaign), track.knots[0])
        planted = (drift.apply(campaign.p1, campaign.times[:, 1], TRACKER) - drift.apply(campaign.p1, start, TRACKER)
                   - drift.apply(campaign.p0, campaign.times[:, 0], TRACKER) + drift.apply(campaign.p0, start, TRACKER))
        mean, cov = track.deflection(campaign)
        within.append(np.abs(mean - planted) <= 3 * np.sqrt(np.einsum("kii->ki", cov)))
    # measured: all 405 coordinates of the three campaigns within 3 sd
    assert np.mean(within) >= 0.99


def test_the_generator_reads_nests_after_the_campaign_leaving_it_unchanged(cell, plan):
    from bayescal.twin.independent.generator import IndependentGenerator

    plain, _ = IndependentGenerator(cell, np.random.default_rng(3)).simulate(plan, 2, "thermal_drift")
    with_nests, truth = IndependentGenerator(cell, np.random.default_rng(3)).simulate(plan, 2, "thermal_drift", nests=True)
    assert np.array_equal(plain.p1, with_nests.p1)
    assert len(truth.nests) == 3 * (1 + 2 * 2 * len(plan.q))
    assert truth.nests.times.min() < with_nests.times.min()
