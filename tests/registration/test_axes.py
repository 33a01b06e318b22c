"""Axis fits checked on sweeps drawn by Rodrigues rotation, written apart from the fit's model."""

from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import norm

from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.registration import Sweeps, fit_axis
from bayescal.registration import axes
from bayescal.registration.axes import span_needed
from bayescal.registration.robust import interval_factor


def _rotate(v, axis, angle):
    """Rodrigues' formula: ``v`` turned by ``angle`` about unit ``axis``."""
    k = axis / np.linalg.norm(axis)
    return v * np.cos(angle) + np.cross(k, v) * np.sin(angle) + k * (k @ v) * (1 - np.cos(angle))


def _sweep(rng, axis, point, reflectors, angles, noise):
    """Readings of reflectors (positions at q = 0) turned about the axis through ``point``."""
    rows = [(name, q, point + _rotate(p0 - point, axis, q)) for name, p0 in reflectors.items() for q in angles]
    xyz = noise.measure(np.array([r[2] for r in rows]), rng)
    q = np.array([[r[1], 0.0] for r in rows])
    n = len(rows)
    return Sweeps(np.zeros(n, int), q, np.array([r[0] for r in rows]), xyz, np.arange(2, n + 2), "sim.csv")


def _case(rng):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    point = rng.uniform(-3, 3, size=3)
    reflectors = {name: point + rng.uniform(-0.8, 0.8, size=3) for name in ("R1", "R2", "R3")}
    return axis, point, reflectors


def test_recovers_axis_within_its_uncertainty():
    rng = np.random.default_rng(7)
    noise = TrackerNoise()
    z, dof = [], []
    for _ in range(40):
        axis, point, reflectors = _case(rng)
        fit = fit_axis(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-60, 60, 9)), noise), 0, noise)
        nearest = point - (point @ axis) * axis
        assert fit.direction @ axis > 0.999
        err = np.concatenate([fit.direction - axis, fit.point - nearest])
        # Fixed directions across the true axis: those of the estimated covariance's eigenvectors would pick the
        # directions its noise made small.
        across = np.linalg.svd(axis[None])[2][1:]
        for contrast in [np.r_[b, 0, 0, 0] for b in across] + [np.r_[0, 0, 0, b] for b in across]:
            z.append(abs(contrast @ err) / np.sqrt(contrast @ fit.cov @ contrast))
            dof.append(fit.interval_dof(contrast))
    z, dof = np.array(z), np.array(dof)
    # 160 components: within the interval with the normal's ±1 sd coverage in 68 % of cases (binomial sd 3.7 %;
    # measured 60.6 %), within the ±4 sd one always (a chance of 6e-5 each).
    assert np.mean(z < interval_factor(1.0, dof)) == pytest.approx(0.683, abs=0.11)
    assert np.all(z < interval_factor(4.0, dof))
    assert fit.direction_sd * 1e3 < 0.5 and fit.residual_rms < 0.2e-3
    assert set(fit.to_json()) >= {"direction", "point_mm", "direction_sd_mrad", "point_sd_mm", "rms_mm"}


def test_mislabelled_reflector_is_reported():
    rng = np.random.default_rng(3)
    noise = TrackerNoise()
    axis, point, reflectors = _case(rng)
    sweep = _sweep(rng, axis, point, reflectors, np.radians(np.linspace(-60, 60, 9)), noise)
    swap = np.flatnonzero(sweep.marker == "R2")[4]
    marker = sweep.marker.copy()
    marker[swap] = "R3"
    bad = Sweeps(sweep.joint, sweep.q, marker, sweep.xyz, sweep.line, sweep.source)
    with pytest.raises(InputError, match=r"sim.csv:\d+.*'marker'.*labelled 'R3' fits as 'R2'"):
        fit_axis(bad, 0, noise)


@pytest.mark.slow
def test_coverage_nominal_over_200_registrations():
    rng = np.random.default_rng(11)
    noise = TrackerNoise()
    z, dof = [], []
    for _ in range(200):
        axis, point, reflectors = _case(rng)
        fit = fit_axis(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-60, 60, 9)), noise), 0, noise)
        err = np.concatenate([fit.direction - axis, fit.point - (point - (point @ axis) * axis)])
        across = np.linalg.svd(axis[None])[2][1:]
        for contrast in [np.r_[b, 0, 0, 0] for b in across] + [np.r_[0, 0, 0, b] for b in across]:
            z.append(abs(contrast @ err) / np.sqrt(contrast @ fit.cov @ contrast))
            dof.append(fit.interval_dof(contrast))
    z, dof = np.array(z), np.array(dof)
    # Independent readings at the tracker's law, the Student-t intervals of the sds clustered by angle: measured
    # 65.4 / 96.5 / 99.9 % within those of ±1/2/3 sd's coverage (4.5 degrees of freedom in the median); binomial sd
    # over the 200 fits, 3 allowed.
    for k in (1, 2, 3):
        nominal = 2 * norm.cdf(k) - 1
        assert np.mean(z < interval_factor(k, dof)) == pytest.approx(nominal, abs=3 * np.sqrt(nominal * (1 - nominal) / 200))


def test_the_noise_is_learned_and_the_sds_follow_it():
    rng = np.random.default_rng(5)
    law = TrackerNoise()
    axis, point, reflectors = _case(rng)
    angles = np.radians(np.linspace(-60, 60, 9))
    clean = fit_axis(_sweep(rng, axis, point, reflectors, angles, law), 0, law)
    noisy = fit_axis(_sweep(rng, axis, point, reflectors, angles, replace(law, factor=5 * law.factor)), 0, law)
    assert clean.excess == pytest.approx(1.0, abs=0.3) and noisy.excess == pytest.approx(5.0, rel=0.25)
    assert noisy.beyond_tracker and not clean.beyond_tracker
    # Measured 9.9 for an excess of 4.30: the sds follow the scatter, clustered by swept angle, within the sandwich's
    # own noise (nine angles, about four degrees of freedom each).
    assert noisy.direction_sd / clean.direction_sd > 2.0


def test_errors_shared_by_one_angle_widen_the_sds_beyond_the_excess(monkeypatch):
    rng = np.random.default_rng(8)
    law = TrackerNoise()
    axis, point, reflectors = _case(rng)
    angles = np.radians(np.linspace(-60, 60, 7))
    clean = _sweep(rng, axis, point, reflectors, angles, replace(law, factor=0.0))
    # Each angle's readings tilted together by 1 mrad about a direction across the axis (a wobbling joint).
    xyz = clean.xyz.copy()
    for q in angles:
        rows = clean.q[:, 0] == q
        across = np.cross(axis, rng.normal(size=3))
        xyz[rows] = point + np.array([_rotate(v, across, rng.normal() * 1e-3) for v in xyz[rows] - point])
    xyz = law.measure(xyz, rng)
    wobbling = Sweeps(clean.joint, clean.q, clean.marker, xyz, clean.line, clean.source)
    fit = fit_axis(wobbling, 0, law)
    monkeypatch.setattr(axes, "clustered_covariance", lambda jac, residual, bread, cluster: (0 * bread, np.zeros((1, 1, bread.shape[0]))))
    at_law = fit_axis(wobbling, 0, law)
    assert fit.excess == at_law.excess > 3.0
    # Never below the tracker's law's Laplace covariance, its floor.
    assert np.linalg.eigvalsh(fit.cov - at_law.cov).min() > -1e-12 * np.abs(fit.cov).max()
    # Seven angles tell the variance poorly (3.1 degrees of freedom, measured): the sd itself is 0.82 times the
    # excess's here, but the interval with the normal's ±2 sd coverage is 1.3 times the excess's ±2 sd.
    assert fit.direction_dof < 5
    assert fit.half_widths()["direction_mrad"]["2"] > 1.2 * 2 * fit.excess * at_law.direction_sd * 1e3


def test_a_sweep_too_short_to_bend_beyond_the_noise_asks_for_more():
    rng = np.random.default_rng(6)
    law = TrackerNoise()
    axis, point, reflectors = _case(rng)
    assert span_needed(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-30, 30, 7)), law), 0, law) is None
    needed = span_needed(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-0.25, 0.25, 7)), law), 0, law)
    assert np.radians(0.5) < needed < np.radians(30)
    # Ten times the noise asks for about sqrt(10) times the span: the sagitta grows with its square.
    wider = span_needed(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-0.25, 0.25, 7)), law), 0, law, excess=10.0)
    assert wider / needed == pytest.approx(np.sqrt(10), rel=0.1)
