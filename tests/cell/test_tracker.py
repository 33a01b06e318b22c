"""Tests of bayescal.cell.tracker: the distance-dependent Gaussian noise."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.tracker import TrackerNoise


def test_sigma_is_the_scaled_permissible_error():
    tracker = TrackerNoise(position=[1.0, 2.0, 0.0], U0=15e-6, U1=6e-6, factor=0.5)
    points = np.array([[1.0, 2.0, 0.0], [4.0, 6.0, 0.0]])
    np.testing.assert_allclose(tracker.sigma(points), [7.5e-6, 0.5 * (15e-6 + 6e-6 * 5.0)])


def test_measurements_have_the_stated_spread():
    tracker = TrackerNoise(position=np.zeros(3), factor=1.0)
    points = np.tile([3.0, 0.0, 0.0], (20000, 1))
    errors = tracker.measure(points, np.random.default_rng(5)) - points
    expected = 15e-6 + 6e-6 * 3.0
    np.testing.assert_allclose(errors.std(axis=0), expected, rtol=0.03)
    np.testing.assert_allclose(errors.mean(axis=0), 0.0, atol=4 * expected / np.sqrt(len(points)))
    assert abs(np.corrcoef(errors.T)[0, 1]) < 0.05


def test_same_seed_same_readings_and_zero_factor_is_exact():
    tracker = TrackerNoise(position=np.zeros(3))
    points = np.random.default_rng(0).normal(size=(5, 3))
    np.testing.assert_array_equal(tracker.measure(points, np.random.default_rng(1)), tracker.measure(points, np.random.default_rng(1)))
    silent = TrackerNoise(position=np.zeros(3), factor=0.0)
    np.testing.assert_array_equal(silent.measure(points, np.random.default_rng(1)), points)


def test_rejects_negative_parameters():
    with pytest.raises(ValueError, match="factor"):
        TrackerNoise(factor=-1.0)


def test_a_deflection_adds_the_variances_of_its_two_readings():
    tracker = TrackerNoise(position=np.zeros(3), U0=15e-6, U1=6e-6, factor=1.0)
    unloaded, loaded = np.array([[1.0, 0.0, 0.0], [0.0, 3.0, 0.0]]), np.array([[2.0, 0.0, 0.0], [0.0, 0.0, 4.0]])
    # σ(1 m) = 21 μm, σ(2 m) = 27 μm; σ(3 m) = 33 μm, σ(4 m) = 39 μm
    np.testing.assert_allclose(tracker.deflection_variance(unloaded, loaded), [21e-6**2 + 27e-6**2, 33e-6**2 + 39e-6**2])
    assert tracker.sigma_range(unloaded, loaded) == pytest.approx((21e-6, 39e-6))
