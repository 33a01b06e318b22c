"""Axis fits checked on sweeps drawn by Rodrigues rotation, written apart from the fit's model."""

from dataclasses import replace

import numpy as np
import pytest

from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.registration import Sweeps, fit_axis
from bayescal.registration import axes
from bayescal.registration.axes import span_needed


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
    z = []
    for _ in range(40):
        axis, point, reflectors = _case(rng)
        fit = fit_axis(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-60, 60, 9)), noise), 0, noise)
        nearest = point - (point @ axis) * axis
        assert fit.direction @ axis > 0.999
        err = np.concatenate([fit.direction - axis, fit.point - nearest])
        w, V = np.linalg.eigh(fit.cov)
        keep = w > w.max() * 1e-9
        z.append(float(np.sum((V[:, keep].T @ err) ** 2 / w[keep])))
    # chi-square with 4 degrees of freedom: mean 4; 40 draws give an sd of the mean of about 0.45
    assert np.mean(z) == pytest.approx(4.0, abs=1.5)
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
def test_coverage_at_least_nominal_over_200_registrations():
    rng = np.random.default_rng(11)
    noise = TrackerNoise()
    z = []
    for _ in range(200):
        axis, point, reflectors = _case(rng)
        fit = fit_axis(_sweep(rng, axis, point, reflectors, np.radians(np.linspace(-60, 60, 9)), noise), 0, noise)
        err = np.concatenate([fit.direction - axis, fit.point - (point - (point @ axis) * axis)])
        w, V = np.linalg.eigh(fit.cov)
        keep = w > w.max() * 1e-9
        z.extend(np.abs(V[:, keep].T @ err) / np.sqrt(w[keep]))
    z = np.array(z)
    # Never below the excess-scaled Laplace sds, which are exact for this noise: the sandwich's own noise widens them
    # (measured 78.9 / 98.1 / 100 % within ±1/2/3 sd); sds 1.5 times too wide would cover ±1 sd in 87 %.
    assert np.mean(z < 1) < 0.85
    for k, nominal in ((1, 0.6827), (2, 0.9545), (3, 0.9973)):
        assert np.mean(z < k) > nominal - 3 * np.sqrt(nominal * (1 - nominal) / z.size) - 1 / z.size


def test_the_noise_is_learned_and_the_sds_follow_it():
    rng = np.random.default_rng(5)
    law = TrackerNoise()
    axis, point, reflectors = _case(rng)
    angles = np.radians(np.linspace(-60, 60, 9))
    clean = fit_axis(_sweep(rng, axis, point, reflectors, angles, law), 0, law)
    noisy = fit_axis(_sweep(rng, axis, point, reflectors, angles, replace(law, factor=5 * law.factor)), 0, law)
    assert clean.excess == pytest.approx(1.0, abs=0.3) and noisy.excess == pytest.approx(5.0, rel=0.25)
    assert noisy.beyond_tracker and not clean.beyond_tracker
    # Measured 4.96 for an excess of 4.30: the sds follow the excess, and the sandwich by angle may widen them more.
    assert noisy.direction_sd / clean.direction_sd == pytest.approx(noisy.excess, rel=0.2)


def test_errors_shared_by_one_angle_widen_the_sds_never_below_the_excess(monkeypatch):
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
    monkeypatch.setattr(axes, "_clustered", lambda fit, bread, cluster: np.zeros_like(bread))
    excess_only = fit_axis(wobbling, 0, law)
    assert fit.excess == excess_only.excess > 3.0
    assert np.linalg.eigvalsh(fit.cov - excess_only.cov).min() > -1e-12 * np.abs(fit.cov).max()
    # Measured: the direction's sd 1.11 times the excess's.
    assert fit.direction_sd > 1.05 * excess_only.direction_sd


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
