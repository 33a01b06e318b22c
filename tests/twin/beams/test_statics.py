"""The arm's equilibrium: it converges, it is a stationary point of the potential energy, it is reciprocal,
and its compensator torque is the closed form of Klimchik et al.'s eq. (7) in the generator's own angles."""

from dataclasses import replace

import numpy as np
import pytest

from bayescal.twin.beams.statics import GRAVITY_DIRECTION, TOLERANCE, frames, solve


def point(F, item, p):
    return F[item, :3, :3] @ p + F[item, :3, 3]


def potential(robot, q, twist, deformation, mass):
    """Gravity's, the hanging mass's, the linear compensator's and the elastic elements' energy (J)."""
    F = frames(robot.items, q + robot.zero_offset + twist, deformation)
    height = -GRAVITY_DIRECTION
    energy = sum(m.mass * robot.gravity * height @ point(F, m.item, m.point) for m in robot.masses)
    energy += mass * robot.gravity * height @ point(F, robot.tool.item, robot.tool.load_point)
    c = robot.compensator
    s = np.linalg.norm(point(F, c.item0, c.p0) - point(F, c.item1, c.p1))
    energy += 0.5 * c.K * (s - c.s0) ** 2
    energy += 0.5 * np.sum(twist**2 / robot.joints.k)
    for index, item in enumerate(robot.items):
        if item.kind == "elastic":
            # The hinge is rigid in translation: its energy is its rotations' alone.
            free = np.flatnonzero(np.diag(item.compliance) > 0)
            d = deformation[index, free]
            energy += 0.5 * d @ np.linalg.solve(item.compliance[np.ix_(free, free)], d)
    return energy


def test_every_table3_equilibrium_settles(arm, table3):
    q, masses = table3
    for row, mass in zip(q, masses):
        for load in (0.0, mass):
            state = solve(arm, row, load)
            assert state.residual < TOLERANCE
            assert state.iterations <= 8


@pytest.mark.parametrize("config", [0, 6, 13])
def test_equilibrium_is_a_stationary_point_of_the_energy(arm, table3, config):
    q, masses = table3
    state = solve(arm, q[config], masses[config])
    step = 1e-7
    scale = np.abs(state.torque).max()
    for j in range(6):
        bump = np.zeros(6)
        bump[j] = step
        up = potential(arm, q[config], state.twist + bump, state.deformation, masses[config])
        down = potential(arm, q[config], state.twist - bump, state.deformation, masses[config])
        # A wrong sign or frame in the torques would leave a gradient of the torque's own size.
        assert abs(up - down) / (2 * step) < 1e-4 * scale
    for index in np.flatnonzero([item.kind == "elastic" for item in arm.items]):
        free = np.flatnonzero(np.diag(arm.items[index].compliance) > 0)
        carried = np.abs(np.linalg.solve(arm.items[index].compliance[np.ix_(free, free)], state.deformation[index, free])).max()
        for k in free:
            bump = np.zeros_like(state.deformation)
            bump[index, k] = step
            up = potential(arm, q[config], state.twist, state.deformation + bump, masses[config])
            down = potential(arm, q[config], state.twist, state.deformation - bump, masses[config])
            # Against the largest force or moment the element carries: the rotation vector is conjugate to the
            # moment only to first order in the element's own rotation (about 1e-4 rad here).
            assert abs(up - down) / (2 * step) < 1e-3 * carried


def test_deflections_are_reciprocal(arm, table3):
    """Maxwell–Betti: the vertical motion of B under a weight at A is that of A under the same weight at B."""
    q = table3[0][3]
    a, b = arm.tool.load_point, arm.tool.markers["M1"]
    rest = solve(arm, q).frames[arm.tool.item]

    def sag(where, at):
        T = solve(arm, q, 20.0, load_point=where).frames[arm.tool.item]
        return (T[:3, :3] @ at + T[:3, 3] - rest[:3, :3] @ at - rest[:3, 3])[2]

    assert sag(a, b) == pytest.approx(sag(b, a), rel=2e-3)
    assert abs(sag(a, b)) > 1e-4


@pytest.mark.parametrize("q2_deg", [0.0, -25.24, -56.9, -99.85, -140.0])
def test_compensator_torque_is_eq7(arm, q2_deg):
    weightless = replace(arm, masses=())
    q = np.radians([30.0, q2_deg, 20.0, 0.0, 40.0, 0.0])
    state = solve(weightless, q)
    c = arm.compensator
    column = c.p0 - arm.items[c.item1 - 1].offset[:3, 3]  # from A2's axis, in link 1's frame
    a, psi0 = np.hypot(column[0], column[2]), np.arctan2(column[2], column[0])
    L, phi = np.hypot(c.p1[0], c.p1[2]), np.arctan2(c.p1[2], c.p1[0])
    # A2 turns about +y, which takes the lever's angle in the x-z plane from phi to phi − q2.
    beta = phi - (q[1] + arm.zero_offset[1] + state.twist[1])
    s = np.sqrt(a**2 + L**2 - 2 * a * L * np.cos(beta - psi0))
    expected = -c.K * (1 - c.s0 / s) * a * L * np.sin(psi0 - beta)
    assert state.torque[1] == pytest.approx(expected, rel=1e-9)
    assert abs(expected) > 100.0 or q2_deg <= -99.85
