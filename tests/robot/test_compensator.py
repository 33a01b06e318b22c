import math

import numpy as np
import pytest

from bayescal.robot.compensator import Compensator, CompensatorGeometry, alpha
from bayescal.units import DEG, MM, N_PER_MM

# A KR-270-like compensator: Table II's a_x, a_y and L (Klimchik et al.), phi near Table I's
# lever direction, Table IV's K_c and s0 (read as N/mm and mm).
KR270 = Compensator(184.72 * MM, 685.93 * MM, 120.30 * MM, 99.96 * DEG, 144 * N_PER_MM, 458 * MM)
FULL_TURN = np.linspace(-180, 180, 721) * DEG


def test_spring_length_is_the_distance_between_the_pivots():
    # Build P0, P1, P2 from the convention and compare |P0 P1| with eq 4.
    c = KR270
    p2 = np.zeros(2)
    p0 = p2 - np.array([c.a_x, c.a_y])
    lever = c.phi - FULL_TURN
    p1 = p2 + c.L * np.column_stack([np.cos(lever), np.sin(lever)])
    np.testing.assert_allclose(c.s(FULL_TURN), np.linalg.norm(p1 - p0, axis=1), rtol=1e-12)


def test_spring_is_shortest_with_the_arm_vertical():
    q2 = np.linspace(-150, 0, 15001) * DEG
    s = KR270.s(q2)
    assert abs(q2[np.argmin(s)] / DEG - (KR270.alpha / DEG - 180)) < 0.02
    assert s.min() == pytest.approx(KR270.a - KR270.L, rel=1e-9)


def test_torque_derivative_equals_compensator_stiffness_over_the_whole_turn():
    h = 1e-5
    numeric = (KR270.torque(FULL_TURN + h) - KR270.torque(FULL_TURN - h)) / (2 * h)
    exact = KR270.stiffness(FULL_TURN)
    scale = KR270.K_c * KR270.a * KR270.L
    assert np.max(np.abs(numeric - exact)) / scale < 1e-6
    large = np.abs(exact) > 0.01 * scale
    assert np.max(np.abs(numeric[large] - exact[large]) / np.abs(exact[large])) < 1e-6


def test_stiffness_is_k_c_a_l_eta():
    np.testing.assert_allclose(KR270.stiffness(FULL_TURN), KR270.K_c * KR270.a * KR270.L * KR270.eta(FULL_TURN), rtol=1e-13)


def test_generalized_force_is_minus_torque_by_virtual_work():
    # The spring's potential energy is K_c (s - s0)² / 2; its generalized force on q2 is -dV/dq2 = -M_c.
    h = 1e-6

    def energy(q):
        return 0.5 * KR270.K_c * (KR270.s(q) - KR270.s0) ** 2

    force = -(energy(FULL_TURN + h) - energy(FULL_TURN - h)) / (2 * h)
    np.testing.assert_allclose(force, -KR270.torque(FULL_TURN), atol=1e-6 * KR270.K_c * KR270.a * KR270.L)


def test_torque_is_the_moment_of_the_spring_force_about_p2():
    c = KR270
    q2 = -37 * DEG
    p2 = np.zeros(2)
    p0 = p2 - np.array([c.a_x, c.a_y])
    p1 = p2 + c.L * np.array([math.cos(c.phi - q2), math.sin(c.phi - q2)])
    pull = -c.spring_force(q2) * (p1 - p0) / c.s(q2)
    arm = p1 - p2
    moment_z = arm[0] * pull[1] - arm[1] * pull[0]
    assert c.torque(q2) == pytest.approx(moment_z, rel=1e-12)


def test_compensator_opposes_gravity_with_the_arm_forward():
    # Gravity pulls the forward arm toward +q2; the generalized force -M_c must be negative there.
    assert KR270.torque(-30 * DEG) > 0
    assert KR270.torque(-150 * DEG) < 0


def test_eta_vanishes_at_the_vertical_when_s0_equals_the_shortest_length():
    g = KR270.geometry
    c = g.with_spring(1.0, g.a - g.L)
    assert c.eta(g.alpha - math.pi) == pytest.approx(0.0, abs=1e-12)
    # Without preload eta is -cos(gamma): 1 at the vertical.
    assert g.with_spring(1.0, 0.0).eta(g.alpha - math.pi) == pytest.approx(1.0, abs=1e-12)


def test_joint_stiffness_adds_the_joint_own_stiffness():
    k0 = 1 / (0.302e-6)
    np.testing.assert_allclose(KR270.joint_stiffness(FULL_TURN, k0) - k0, KR270.stiffness(FULL_TURN), rtol=1e-9)


def test_regressor_reproduces_the_joint_stiffness():
    k0 = 1 / (0.302e-6)
    rows = KR270.regressor(FULL_TURN)
    assert rows.shape == (FULL_TURN.size, 3)
    params = np.array([k0, KR270.K_c, KR270.s0 * KR270.K_c])
    np.testing.assert_allclose(rows @ params, KR270.joint_stiffness(FULL_TURN, k0), rtol=1e-12)
    assert KR270.regressor(0.1).shape == (3,)


def test_scalar_in_scalar_out_and_vector_in_vector_out():
    for method in ("s", "spring_force", "torque", "eta", "stiffness", "gamma"):
        assert isinstance(getattr(KR270, method)(0.2), float)
        assert getattr(KR270, method)(np.array([0.1, 0.2, 0.3])).shape == (3,)


def test_alpha_follows_phi_and_the_direction_of_a():
    g = CompensatorGeometry(0.2, 0.0, 0.7, 1.0)
    assert g.alpha == pytest.approx(1.0 - math.pi / 2)
    assert g.a == pytest.approx(0.7)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"L": 0.0},
        {"L": -0.1},
        {"a_x": 0.0, "a_y": 0.0},
        {"L": 0.5, "a_x": 0.3, "a_y": 0.4},
        {"phi": math.nan},
        {"K_c": -1.0},
        {"s0": -0.1},
        {"K_c": math.inf},
    ],
)
def test_invalid_compensators_are_rejected(kwargs):
    values = {"L": 0.18, "a_x": 0.68, "a_y": 0.12, "phi": 1.7, "K_c": 1e5, "s0": 0.45} | kwargs
    with pytest.raises(ValueError):
        Compensator(**values)


def test_geometry_property_drops_the_spring():
    g = KR270.geometry
    assert type(g) is CompensatorGeometry
    assert (g.L, g.a_x, g.a_y, g.phi) == (KR270.L, KR270.a_x, KR270.a_y, KR270.phi)


def test_alpha_of_many_geometries_is_each_geometrys_own():
    geometries = [CompensatorGeometry(0.185, 0.686, 0.120, 1.1), CompensatorGeometry(0.2, -0.5, 0.3, -2.0)]
    many = alpha(*(np.array([getattr(g, name) for g in geometries]) for name in ("phi", "a_x", "a_y")))
    np.testing.assert_allclose(many, [g.alpha for g in geometries], rtol=0, atol=1e-15)
