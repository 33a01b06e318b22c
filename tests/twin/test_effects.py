"""Tests of bayescal.twin.effects: parsing and the physics of each planted effect."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.twin.effects import (
    EFFECTS,
    Backlash,
    CompensatorScale,
    LinkCompliance,
    NonlinearStiffness,
    Outliers,
    ToolCompliance,
    _beam_compliance,
    parse_effect,
)
from bayescal.errors import InputError
from bayescal.robot.stiffness import LinearJoints


def test_parse_names_defaults_and_magnitudes():
    assert parse_effect("backlash") == Backlash(0.015)
    assert parse_effect("backlash=0.02").magnitude == 0.02
    assert set(EFFECTS) == {"compensator", "link_compliance", "tool_compliance", "backlash", "nonlinear_stiffness", "outliers"}
    for text, pattern in [("wobble", "unknown effect 'wobble'"), ("backlash=big", "needs a number"), ("backlash=-1", ">= 0"), ("outliers=2", "between 0 and 1")]:
        with pytest.raises(InputError, match=pattern):
            parse_effect(text)


def test_compensator_scale(cell):
    assert CompensatorScale(0.0).compensator(cell.compensator) is None
    assert CompensatorScale(2.0).compensator(cell.compensator).K_c == pytest.approx(2 * cell.compensator.K_c)
    assert CompensatorScale(1.0).compensator(None) is None


def test_beam_compliance_is_a_cantilever():
    c = _beam_compliance(2.0, EI=4.0, GJ=5.0, EA=8.0)
    np.testing.assert_allclose(c, c.T)
    assert np.all(np.linalg.eigvalsh(c) > 0)
    # tip force in z: deflection l³/3EI up, slope l²/2EI turning x toward +z (negative rotation about y)
    twist = c @ np.array([0, 0, 1.0, 0, 0, 0])
    np.testing.assert_allclose(twist, [0, 0, 8 / 12, 0, -4 / 8, 0])


def test_link_compliance_moves_the_markers_downward_under_a_hanging_load(cell):
    q = np.radians([0, -30, 30, 0, 0, 0])
    points = np.array(list(cell.markers.values()))
    force, couple = np.array([0, 0, -2600.0]), np.zeros(3)
    shift = LinkCompliance(1.0).displacement(cell.robot, q, points, force, couple, cell.load_point)
    assert np.all(shift[:, 2] < -1e-4) and np.all(np.abs(shift) < 2e-3)
    double = LinkCompliance(2.0).displacement(cell.robot, q, points, force, couple, cell.load_point)
    np.testing.assert_allclose(double, 2 * shift)


def test_tool_compliance_tilts_about_the_flange(cell):
    q = np.radians([0, -30, 30, 0, 0, 0])  # flange axis along base x
    points = np.array([[0.2, 0.0, 0.0], [0.0, 0.0, 0.0]])
    force = np.array([0, 0, -1000.0])
    load = np.array([0.25, 0.0, 0.0])
    shift = ToolCompliance(1.0).displacement(cell.robot, q, points, force, np.zeros(3), load)
    # moment 250 N·m about base y tilts the tool down by 250 μrad: 50 μm at 0.2 m, nothing at the flange
    np.testing.assert_allclose(shift[0], [0, 0, -50e-6], atol=1e-9)
    np.testing.assert_allclose(shift[1], 0.0, atol=1e-15)


def test_joint_laws(cell):
    linear = LinearJoints(cell.compliances)
    torque = np.array([0.0, -5000.0, 2000.0, 10.0, -300.0, 0.5])
    dead = Backlash(0.015).joints(linear, cell.robot)
    extra = dead.deflection(torque) - linear.deflection(torque)
    assert extra[1] == pytest.approx(-np.radians(0.015), rel=1e-6)
    assert extra[2] == pytest.approx(np.radians(0.015), rel=1e-3)
    assert extra[0] == 0.0 and abs(extra[5]) < 0.1 * np.radians(0.015)
    hard = NonlinearStiffness(0.3).joints(linear, cell.robot)
    ratio = hard.deflection(torque) / np.where(torque == 0, 1, linear.deflection(torque))
    assert ratio[1] == pytest.approx(1 / (1 + 0.3 * 5000 / 25000))
    for law in (dead, hard):
        h = 1e-3
        numeric = (law.deflection(torque + h) - law.deflection(torque - h)) / (2 * h)
        np.testing.assert_allclose(law.slope(torque), numeric, rtol=1e-5)


def test_outliers_hit_the_stated_fraction():
    readings = np.zeros((20000, 3))
    corrupted = Outliers(0.01).corrupt(readings, np.random.default_rng(2))
    size = np.linalg.norm(corrupted, axis=1)
    hit = size > 0
    assert 0.007 < hit.mean() < 0.013
    assert np.all((size[hit] >= 0.5e-3) & (size[hit] <= 2e-3))
