"""The beam model against the closed forms of a Timoshenko cantilever, through the generator's own equilibrium."""

import numpy as np
import pytest

from bayescal.twin.beams.beam import box_section, timoshenko_compliance, tube_section
from bayescal.twin.beams.statics import frames, solve

from .conftest import cantilever

G_ACCEL = 9.80665
DEEP = box_section(0.20, 0.40, 0.010, 200e9, 78e9)
"""A deep, short-span box: shear is 8 % of its tip deflection over 0.8 m, so leaving shear out fails the test."""


def tip(robot, state):
    """The tip's displacement (3,) m and rotation (3,) rad (sin of the angle about its axis: exact to angle³/6)."""
    T = state.frames[robot.tool.item]
    rest = frames(robot.items, np.zeros(6))[robot.tool.item]
    R = T[:3, :3]
    return T[:3, 3] - rest[:3, 3], np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / 2


@pytest.mark.parametrize("section", [DEEP, tube_section(0.28, 0.012, 169e9, 66e9)])
def test_compliance_is_symmetric_positive_definite(section):
    C = timoshenko_compliance(0.9, section)
    np.testing.assert_array_equal(C, C.T)
    assert np.linalg.eigvalsh(C).min() > 0


@pytest.mark.parametrize("stations", [(), (0.3,), (0.2, 0.5, 0.7)])
def test_tip_load_deflection_and_slope_match_timoshenko(stations):
    length, mass = 0.8, 2000.0
    robot = cantilever(DEEP, length, stations)
    displacement, turn = tip(robot, solve(robot, np.zeros(6), mass))
    P = mass * G_ACCEL
    bending = P * length**3 / (3 * DEEP.E * DEEP.I_y)
    shear = P * length / (DEEP.G * DEEP.shear_z)
    assert shear > 0.05 * bending
    np.testing.assert_allclose(displacement[2], -(bending + shear), rtol=1e-6)
    np.testing.assert_allclose(turn[1], P * length**2 / (2 * DEEP.E * DEEP.I_y), rtol=1e-6)


def test_load_at_a_station_matches_the_closed_form_beyond_it():
    length, a, mass = 0.8, 0.3, 2000.0
    robot = cantilever(DEEP, length, (a,), masses=((0, mass),))
    displacement, _ = tip(robot, solve(robot, np.zeros(6)))
    P = mass * G_ACCEL
    expected = P * a**2 * (3 * length - a) / (6 * DEEP.E * DEEP.I_y) + P * a / (DEEP.G * DEEP.shear_z)
    np.testing.assert_allclose(displacement[2], -expected, rtol=1e-6)


def test_offset_load_twists_by_the_torsion_constant():
    length, mass, arm = 0.8, 500.0, 0.25
    robot = cantilever(DEEP, length)
    _, turn = tip(robot, solve(robot, np.zeros(6), mass, load_point=np.array([0.0, arm, 0.0])))
    # A weight P at +y turns the tip about −x by P·arm·ℓ/(GJ).
    np.testing.assert_allclose(turn[0], -mass * G_ACCEL * arm * length / (DEEP.G * DEEP.J), rtol=1e-5)
