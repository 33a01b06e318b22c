"""Tests of bayescal.twin.arcs: the geometry's simulated tracker points, with and without a planted effect."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.geometry.arcs import LEVER_MARKER, MarkerLayout
from bayescal.twin.arcs import PLANTED, simulate_markers
from bayescal.units import DEG, MM

LAYOUT = MarkerLayout(
    p2=np.array([0.05, -0.02]), L=0.160, phi=70 * DEG, sense=-1, p0=np.array([-0.62, -0.15]),
    cylinder={"P01": (0.150, 175 * DEG), "P02": (0.170, 215 * DEG)},
)
ANGLES = np.radians(np.linspace(-150.0, 10.0, 8))


def _by_marker(points):
    return {name: points.of(name)[1][:, :2] for name in (LEVER_MARKER, "P01", "P02")}


def test_without_noise_or_effect_the_points_are_the_layouts():
    points = _by_marker(simulate_markers(LAYOUT, ANGLES, np.random.default_rng(0), sigma=0.0))
    for name, exact in LAYOUT.positions(ANGLES).items():
        np.testing.assert_allclose(points[name], exact, atol=1e-15)


def test_the_noise_has_the_asked_spread_and_the_seed_fixes_it():
    sigma = 0.05 * MM
    many = np.radians(np.linspace(-150.0, 10.0, 1600))  # one reading per marker and angle, as a points file has
    points = simulate_markers(LAYOUT, many, np.random.default_rng(1), sigma=sigma)
    exact = LAYOUT.positions(many)
    errors = np.concatenate([points.of(name)[1][:, :2] - exact[name] for name in exact])
    assert np.std(errors) == pytest.approx(sigma, rel=0.05)
    again = simulate_markers(LAYOUT, many, np.random.default_rng(1), sigma=sigma)
    np.testing.assert_array_equal(again.xyz, points.xyz)


@pytest.mark.parametrize("effect", [name for name in PLANTED if name != "closed_loop"])
def test_every_physical_effect_moves_the_markers_off_the_layout(effect):
    planted = _by_marker(simulate_markers(LAYOUT, ANGLES, np.random.default_rng(0), effect, sigma=0.0))
    shift = max(np.max(np.linalg.norm(planted[name] - exact, axis=1)) for name, exact in LAYOUT.positions(ANGLES).items())
    # at its default magnitude each effect moves some marker by more than a tenth of a mm (0.58 to 1.96 mm here)
    assert shift > 0.1 * MM


def test_an_unknown_effect_is_refused():
    with pytest.raises(ValueError, match="unknown effect"):
        simulate_markers(LAYOUT, ANGLES, np.random.default_rng(0), "bent_tracker")
