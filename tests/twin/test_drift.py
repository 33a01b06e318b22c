import numpy as np
import pytest

from bayescal.twin.drift import NESTS, TIMELINE, TrackerDrift, nest_times, reading_times
from bayescal.twin.simulator import DigitalTwin


def test_reading_times_follow_the_timeline():
    times = reading_times(2, 3, 3)
    assert times.shape == (2, 3, 3, 2)
    assert np.all(times[..., 1] - times[..., 0] == TIMELINE["hang"])
    assert times[0, 1, 0, 0] - times[0, 0, 0, 0] == TIMELINE["hang"] + TIMELINE["unhang"]
    visits = nest_times(times, 3)
    # a visit before the campaign, and two per repeat (while the load hangs, after it is removed)
    assert visits.shape == (1 + 2 * 3 * 2, 3) and visits[0, -1] < times[0, 0, 0, 0]
    assert nest_times(times, 3, np.array([True, False])).shape == (1 + 2 * 3, 3)


def test_the_drift_is_zero_at_time_zero_and_steady_without_its_walk():
    drift = TrackerDrift(0.3)
    frame = drift.frame(np.array([0.0, 3600.0]), np.random.default_rng(0))
    assert np.allclose(frame[0], 0.0)
    # one hour: the steady 0.3 mm plus a random walk of sd 0.15 mm
    assert 0.0 < np.linalg.norm(frame[1, :3]) < 1e-3
    with pytest.raises(ValueError, match="rate >= 0"):
        TrackerDrift(-1.0)


def test_nests_and_campaign_move_with_one_drift(cell, plan):
    still, still_nests = DigitalTwin(cell).simulate_with_nests(plan, 2, np.random.default_rng(8))
    moved, moved_nests = DigitalTwin(cell, drift=TrackerDrift(0.4)).simulate_with_nests(plan, 2, np.random.default_rng(8))
    assert np.array_equal(still.times, moved.times) and np.array_equal(still_nests.times, moved_nests.times)
    assert set(moved_nests.name) == set(NESTS)
    shift = np.linalg.norm(moved_nests.position - still_nests.position, axis=1)
    assert shift[-1] > shift[0] and np.abs(moved.p1 - still.p1).max() > 1e-5
    # without the drift, the timed campaign is the untimed one
    assert np.array_equal(still.p0, DigitalTwin(cell).simulate(plan, 2, np.random.default_rng(8)).p0)


def test_in_passes_a_configurations_repeats_lie_a_pass_apart():
    times = reading_times(4, 3, 2, passes=True)
    slot = TIMELINE["hang"] + TIMELINE["unhang"] + TIMELINE["move"]
    assert times[0, 1, 0, 0] - times[0, 0, 0, 0] == 4 * slot and times[1, 0, 0, 0] - times[0, 0, 0, 0] == slot
    visits = nest_times(times, 3)
    assert np.all(np.diff(visits[:, 0]) > 0) and visits[0, -1] < times[..., 0].min()
