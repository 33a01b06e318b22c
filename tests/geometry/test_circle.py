import numpy as np
import pytest

from bayescal.geometry.circle import geometric_fit, hyper_fit, kasa_fit, known_angle_crb, unknown_angle_crb

CENTRE = np.array([0.3, -1.2])
RADIUS = 0.185


def arc(angles):
    return CENTRE + RADIUS * np.column_stack([np.cos(angles), np.sin(angles)])


@pytest.mark.parametrize("fit", [kasa_fit, hyper_fit, geometric_fit])
def test_exact_points_give_the_exact_circle(fit):
    result = fit(arc(np.linspace(-0.5, 2.0, 6)))
    np.testing.assert_allclose(result.centre, CENTRE, atol=1e-12)
    assert result.radius == pytest.approx(RADIUS, abs=1e-12)
    assert np.max(np.abs(result.residuals)) < 1e-12


def test_geometric_fit_minimises_orthogonal_distances():
    rng = np.random.default_rng(3)
    points = arc(np.linspace(0, 2.5, 8)) + 1e-3 * rng.standard_normal((8, 2))
    best = geometric_fit(points)

    def cost(centre, radius):
        return np.sum((np.linalg.norm(points - centre, axis=1) - radius) ** 2)

    base = cost(best.centre, best.radius)
    assert base == pytest.approx(np.sum(best.residuals**2))
    for step in np.eye(3) * 1e-5:
        assert cost(best.centre + step[:2], best.radius + step[2]) > base
        assert cost(best.centre - step[:2], best.radius - step[2]) > base


def test_hyper_fit_is_less_biased_than_kasa_on_a_short_noisy_arc():
    rng = np.random.default_rng(0)
    angles = np.linspace(0, 1.0, 10)
    kasa, hyper = [], []
    for _ in range(400):
        points = arc(angles) + 5e-3 * rng.standard_normal((10, 2))
        kasa.append(kasa_fit(points).radius)
        hyper.append(hyper_fit(points).radius)
    # Kåsa's radius is biased low on short arcs; the hyper fit has no essential bias.
    assert np.mean(kasa) < RADIUS - 5 * np.std(kasa) / np.sqrt(400)
    assert abs(np.mean(hyper) - RADIUS) < abs(np.mean(kasa) - RADIUS) / 2


def test_fits_reject_fewer_than_three_points():
    with pytest.raises(ValueError):
        hyper_fit(arc(np.array([0.0, 1.0])))


def test_known_angle_bound_on_a_full_circle():
    # Equally spaced angles over a full turn decouple all parameters.
    m, sigma = 8, 0.05
    angles = np.arange(m) * 2 * np.pi / m
    for sense in (1, -1):
        bound = known_angle_crb(angles, RADIUS, 0.4, sigma, sense)
        np.testing.assert_allclose(np.diag(bound), [sigma**2 / m, sigma**2 / m, sigma**2 / m, sigma**2 / (m * RADIUS**2)])
        np.testing.assert_allclose(bound - np.diag(np.diag(bound)), 0, atol=1e-18)


def test_unknown_angle_bound_on_a_full_circle():
    m, sigma = 8, 0.05
    bound = unknown_angle_crb(np.arange(m) * 2 * np.pi / m, sigma)
    np.testing.assert_allclose(np.diag(bound), [2 * sigma**2 / m, 2 * sigma**2 / m, sigma**2 / m])


def test_known_angles_help_most_on_short_arcs():
    angles = np.linspace(0, 1.0, 6)
    known = known_angle_crb(angles, RADIUS, 0.0, 1.0, 1)
    unknown = unknown_angle_crb(angles, 1.0)
    assert unknown[2, 2] > 10 * known[2, 2]


def test_known_angle_bound_rejects_a_bad_sense():
    with pytest.raises(ValueError):
        known_angle_crb([0, 1, 2], 1.0, 0.0, 1.0, sense=0)
