"""Repeat groups as nests of unknown position, the walk fitted to them, and the walk's draws."""

from dataclasses import replace

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.registration.nest_drift import fit_nest_drift, motion_matrix
from bayescal.registration.repeats import fit_drift, repeat_groups

from .test_nest_drift import RATE, TRACKER, steady_nests


def steady_campaign(noise, rng, configs=6, repeats=3, passes=True) -> tuple[Campaign, np.ndarray]:
    """Two markers per configuration, read unloaded then loaded 300 s later, the configurations' repeats in passes (or
    back to back), the frame drifting at :data:`RATE`; and the planted drift in each deflection (N, 3) m."""
    config, repeat = np.meshgrid(np.arange(1, configs + 1), np.arange(1, repeats + 1), indexing="ij")
    slot = (repeat - 1) * configs + config - 1 if passes else (config - 1) * repeats + repeat - 1
    keys = np.stack([config.ravel(), repeat.ravel(), slot.ravel()], axis=1).repeat(2, axis=0)
    marker = np.tile(np.array(["A", "B"]), len(keys) // 2)
    start = keys[:, 2] * 540.0 + 15.0 * (marker == "B")
    times = np.stack([start, start + 300.0], axis=1)
    p0 = np.array([[1.5, 0.2, 1.0], [1.6, 0.3, 1.0]])[(marker == "B").astype(int)] + 0.1 * keys[:, :1]
    p1 = p0 + [0.0, 0.0, -1e-3]
    moved = [p + np.einsum("kij,j,k->ki", motion_matrix(p, TRACKER), RATE, t) for p, t in ((p0, times[:, 0]), (p1, times[:, 1]))]
    moved = [m + rng.normal(size=m.shape) * noise.sigma(m)[:, None] for m in moved]
    n = len(keys)
    campaign = Campaign(keys[:, 0], keys[:, 1], marker, np.zeros((n, 6)), np.zeros((n, 6)), moved[0], moved[1],
                        np.zeros(n, int), times=times)
    planted = np.einsum("kij,j,k->ki", motion_matrix(p1, TRACKER), RATE, times[:, 1]) - np.einsum(
        "kij,j,k->ki", motion_matrix(p0, TRACKER), RATE, times[:, 0])
    return campaign, planted


def test_a_configurations_first_unloaded_reading_is_no_repeat_and_a_group_needs_distinct_times(cell):
    campaign, _ = steady_campaign(cell.tracker, np.random.default_rng(1))
    groups = repeat_groups(campaign.p0, campaign.p1, campaign.times, campaign.config, campaign.marker)
    # loaded: three readings per marker and configuration; unloaded: the later two
    assert len(groups) == 6 * 2 * (3 + 2) and np.unique(groups.name).size == 6 * 2 * 2
    assert not np.isin(campaign.times[campaign.repeat == 1, 0], groups.times).any()
    once = replace(campaign, times=np.where(campaign.repeat[:, None] == 1, campaign.times, np.nan))
    assert repeat_groups(once.p0, once.p1, once.times, once.config, once.marker) is None
    assert fit_drift(replace(campaign, times=None), cell.tracker) is None


def test_a_drift_measured_from_repeats_in_passes_alone_covers_the_planted_one(cell):
    campaign, planted = steady_campaign(cell.tracker, np.random.default_rng(2))
    track = fit_drift(campaign, cell.tracker)
    mean, cov = track.deflection(campaign)
    z = (mean - planted) / np.sqrt(np.einsum("kii->ki", cov))
    assert track.n_nests == 0 and track.n_groups == 24 and np.all(np.abs(z) < 3.0)
    assert track.to_json(campaign)["source"] == "repeats"
    # with nests the walk takes both, counting each kind
    both = fit_drift(campaign, cell.tracker, steady_nests(cell.tracker, np.random.default_rng(3), visits=20, every=540.0))
    assert (both.n_nests, both.n_groups) == (3, 24) and both.to_json(campaign)["source"] == "reference nests and repeats"


def test_the_walks_draws_have_its_mean_and_covariance(cell):
    track = fit_nest_drift(steady_nests(cell.tracker, np.random.default_rng(4), visits=6), cell.tracker)
    times = np.array([-100.0, 250.0, 600.0, 1900.0, 2000.0, 4000.0])
    draws = track.draws(times, np.random.default_rng(5), 4000)
    points = np.tile([1.5, 0.5, 1.2], (len(times), 1))
    moved = np.einsum("kij,dkj->dki", motion_matrix(points, track.tracker), draws)
    mean, cov = track.motion(points, times)
    sd = np.sqrt(np.einsum("kii->ki", cov))
    # 4000 draws: the mean within 5 of its standard errors, the variance within 10 %
    assert np.all(np.abs(moved.mean(axis=0) - mean) < 5 * sd / np.sqrt(4000))
    assert np.allclose(moved.var(axis=0), sd**2, rtol=0.1)
    # two times on one stretch share its bridge: their difference has the walk's covariance, not the sum of both
    change = moved[:, 4] - moved[:, 3]
    _, pair = track.change(points[3:4], points[4:5], times[3:5][None, :])
    assert np.allclose(change.var(axis=0), np.diag(pair[0]), rtol=0.1)


def test_each_removed_draw_takes_one_draw_of_the_drift_out_of_both_readings(cell):
    campaign, _ = steady_campaign(cell.tracker, np.random.default_rng(2))
    track = fit_drift(campaign, cell.tracker)
    draws = track.removed_draws(campaign, np.random.default_rng(6), 2000)
    removed = track.remove(campaign)
    deflections = np.array([(draw.p1 - draw.p0) for draw in draws])
    _, cov = track.deflection(campaign)
    sd = np.sqrt(np.einsum("kii->ki", cov))
    # about the posterior mean's removal, the deflections spread as the drift's posterior in them; no variance added
    assert np.all(np.abs(deflections.mean(axis=0) - (removed.p1 - removed.p0)) < 5 * sd / np.sqrt(2000))
    assert np.allclose(deflections.var(axis=0), sd**2, rtol=0.15)
    assert all(draw.added_variance is None for draw in draws) and removed.added_variance is not None
    # the unloaded readings of two rows read 15 s apart move together: the draws carry the walk's correlation
    a, b = (np.array([draw.p0[k, 0] for draw in draws]) for k in (0, 1))
    assert np.corrcoef(a, b)[0, 1] > 0.9
