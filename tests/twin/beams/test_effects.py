"""The planted physical effects do what docs/generators.md says they do."""

import numpy as np
import pytest

from bayescal.twin.beams.campaign import _equilibria, _markers
from bayescal.twin.beams.effects import GAS_RATE, HARDENING, PLAY_URAD, plant
from bayescal.twin.beams.schedule import plan_schedule
from bayescal.twin.beams.statics import frames


def deflections(robot, table3, order):
    """Noise-free (steps, markers, 3) loaded-minus-unloaded displacements (m), steps sorted by (config, repeat)."""
    q, masses = table3
    schedule = plan_schedule(len(q), 2, 3, 0, order, np.random.default_rng(0))
    pairs = _equilibria(robot, q, masses, schedule, np.random.default_rng(0))
    moved = {(s.config, s.repeat): _markers(robot, b) - _markers(robot, a) for s, (a, b) in zip(schedule.steps, pairs)}
    return np.array([moved[key] for key in sorted(moved)])


def test_lost_motion_depends_on_the_order_of_measurement(arm, table3):
    backlash, _ = plant(arm, "lost_motion", 1.0)
    change = np.abs(deflections(backlash, table3, "together") - deflections(backlash, table3, "passes")).max()
    assert change > 5e-6
    assert np.array_equal(deflections(arm, table3, "together"), deflections(arm, table3, "passes"))
    # No more than every band crossed at once, seen 3.5 m out.
    assert np.abs(deflections(backlash, table3, "together") - deflections(arm, table3, "together")).max() < PLAY_URAD.sum() * 1e-6 * 3.5


def test_hardening_gear_stiffness_grows_with_torque(arm):
    hard, _ = plant(arm, "nonlinear_stiffness", 1.0)
    laws = hard.joints
    torque = 0.5 * laws.rated
    h = 1e-3 * laws.rated
    stiffness = 2 * h / (laws.twist(torque + h) - laws.twist(torque - h))
    np.testing.assert_allclose(stiffness * laws.k, 1 + HARDENING * 0.5, rtol=1e-6)
    np.testing.assert_allclose(laws.twist(-torque), -laws.twist(torque))


def test_gas_spring_keeps_the_force_and_doubles_the_rate_with_the_arm_horizontal(arm):
    gas, _ = plant(arm, "compensator", 1.0)
    c, coil = gas.compensator, arm.compensator
    s_ref = c.s0 + c.e_ref
    assert c.force(s_ref) == pytest.approx(coil.force(s_ref), rel=1e-12)
    rate = (c.force(s_ref + 1e-6) - c.force(s_ref - 1e-6)) / 2e-6
    assert rate == pytest.approx(GAS_RATE * coil.K, rel=1e-6)
    lengths = []
    for q2 in np.radians(np.linspace(-146.0, 0.0, 30)):
        F = frames(arm.items, np.array([0.0, q2, 0.0, 0.0, 0.0, 0.0]))
        p0 = F[c.item0, :3, :3] @ c.p0 + F[c.item0, :3, 3]
        p1 = F[c.item1, :3, :3] @ c.p1 + F[c.item1, :3, 3]
        lengths.append(np.linalg.norm(p1 - p0))
    forces = [c.force(s) for s in sorted(lengths)]
    assert min(forces) > 0 and np.all(np.diff(forces) > 0)
