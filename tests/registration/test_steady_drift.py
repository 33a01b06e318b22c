import numpy as np
import pytest

from bayescal.cell.nests import Nests
from bayescal.registration.nest_drift import fit_nest_drift
from bayescal.registration.steady_drift import fit_steady_drift
from bayescal.twin.independent.noise import FrameDrift
from bayescal.units import HOUR

POINTS = np.array([[2.2, 0.3, 1.4], [1.9, -0.6, 0.9], [1.4, 0.8, 1.7], [2.4, -0.2, 0.6]])
"""Four markers' states, m: what a configuration's repeat groups are to the drift."""


def _groups(drift: FrameDrift, tracker, rng, spans=8, visits=3, scatter=1.0) -> Nests:
    """Each point read ``visits`` times 12 min apart within each of ``spans`` stretches 40 min apart, a new point (name)
    per stretch: groups whose readings span 24 min, with 16 min between stretches that no group spans; the readings'
    noise ``scatter`` times the tracker's."""
    names, times, points = [], [], []
    for stretch in range(spans):
        for visit in range(visits):
            for k, point in enumerate(POINTS):
                names.append(f"s{stretch}p{k}")
                times.append(2400.0 * stretch + 720.0 * visit + 20.0 * k)
                points.append(point)
    times, points = np.array(times), np.array(points)
    readings = drift.apply(points, times, tracker.position) + rng.normal(size=points.shape) * scatter * tracker.sigma(points)[:, None]
    return Nests(np.array(names), times, readings, np.zeros(len(times), dtype=int))


def _steady(rng) -> FrameDrift:
    return FrameDrift.draw(rng, rate=0.2e-3 / HOUR, cycle=0.0, period=1800.0, spin_rate=0.02e-3 / HOUR)


@pytest.mark.parametrize("scatter", [1.0, 2.5])
def test_a_steady_rate_is_recovered_within_its_uncertainty(cell, scatter):
    # readings scattering more than the tracker's noise says (a robot's repeatability between visits) widen the rate's
    # sd by their own scatter, so that it still covers
    z = []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        drift = _steady(rng)
        fitted = fit_steady_drift(_groups(drift, cell.tracker, rng, scatter=scatter), cell.tracker)
        planted = np.concatenate([drift.velocity, drift.spin])
        z.append((fitted.rate - planted) / np.sqrt(np.diag(fitted.cov)))
    z = np.abs(np.array(z))
    # 240 coordinates: within 2 sd at about the nominal 95 %, and none beyond 4 sd
    assert 0.90 <= np.mean(z < 2.0) <= 0.99 and z.max() < 4.0, (np.mean(z < 2.0), z.max())


def test_the_rate_carries_the_drift_over_a_stretch_no_group_spans(cell):
    # a deflection read in the 16 min between two stretches: the walk alone knows nothing of the frame's change there
    rng = np.random.default_rng(3)
    drift = _steady(rng)
    groups = _groups(drift, cell.tracker, rng)
    p0 = np.array([[1.8, 0.1, 1.2]])
    p1 = p0 + [0.0, 0.0, -2e-3]
    times = np.array([[1500.0 + 2400.0, 2200.0 + 2400.0]])
    planted = (drift.apply(p1, times[:, 1], cell.tracker.position) - p1) - (drift.apply(p0, times[:, 0], cell.tracker.position) - p0)
    mean, cov = fit_steady_drift(groups, cell.tracker).change(p0, p1, times)
    walk_mean, _ = fit_nest_drift(groups, cell.tracker).change(p0, p1, times)
    sd = np.sqrt(np.diag(cov[0]))
    assert np.all(np.abs(mean[0] - planted[0]) < 3.0 * sd), (mean, planted, sd)
    assert np.linalg.norm(mean[0] - planted[0]) < 0.2 * np.linalg.norm(planted[0])
    assert np.linalg.norm(walk_mean[0] - planted[0]) > 0.8 * np.linalg.norm(planted[0])


def test_what_the_rate_leaves_goes_to_the_walk(cell):
    # a 30 min cycle of 0.1 mm, well above the noise: the walk of what the rate leaves takes it up; a frame without any
    # drift leaves it at a diffusion a hundred times smaller
    rng = np.random.default_rng(4)
    cycling = FrameDrift.draw(rng, rate=0.0, cycle=100e-6, period=1800.0, spin_rate=0.0)
    still = FrameDrift(np.zeros(3), np.zeros(3), 1800.0, 0.0, np.zeros(3))
    moving = fit_steady_drift(_groups(cycling, cell.tracker, rng, visits=6), cell.tracker).wander.diffusion
    fixed = fit_steady_drift(_groups(still, cell.tracker, rng, visits=6), cell.tracker).wander.diffusion
    assert moving > 100 * fixed, (moving, fixed)
