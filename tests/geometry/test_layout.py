"""Tests of bayescal.geometry.layout: where the compensator's markers are, and back."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.geometry.layout import circular_mean, cylinder_direction, cylinder_points, lever_angle, lever_points, marker_offset


def test_marker_offset_reads_back_the_offset_a_marker_was_placed_at():
    q2 = np.radians(np.linspace(-120.0, -20.0, 7))
    lever_x, lever_y = lever_points(0.68, 0.12, 0.185, lever_angle(1.1, -1, q2))
    direction = cylinder_direction(lever_x, lever_y, 0.0, 0.0)
    x, y, _ = cylinder_points(0.0, 0.0, direction, 0.09, 2.5, turn=0.01 * q2)
    wrapped = np.angle(np.exp(1j * marker_offset(x, y, 0.0, 0.0, direction)))
    np.testing.assert_allclose(wrapped, 2.5 + 0.01 * q2, atol=1e-12)


@pytest.mark.parametrize("centre", [0.3, np.pi - 0.01, -np.pi + 0.01])
def test_circular_mean_is_the_middle_of_angles_across_the_cut(centre):
    # angles on both sides of ±π average to π, not to 0 as their arithmetic mean would
    angles = np.angle(np.exp(1j * (centre + np.array([-0.05, 0.0, 0.05]))))
    assert np.exp(1j * circular_mean(angles)) == pytest.approx(np.exp(1j * centre))
