"""Tests of bayescal.twin.independent: the independent campaign generator.

The package's own model (``bayescal.robot.stiffness``) is called here only to check
that, with the cell's truth and no effect, the generator's separately written
equilibrium gives the same deflections.
"""

from __future__ import annotations

import contextlib
import io
import json
from dataclasses import replace

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign, write_campaign
from bayescal.cli import main
from bayescal.errors import InputError
from bayescal.robot.stiffness import ElasticArm
from bayescal.twin.independent import CAUSES, EFFECTS, IndependentGenerator, random_plan
from bayescal.twin.independent.noise import RADIAL_RATIO, TrackerReadout
from bayescal.twin.independent.solver import SpringLinkage
from bayescal.twin.independent.structure import ApproachPlay, BeamSection, GearPlay, cantilever_twist

CHANGE_UM = {
    "stiff_spring": 6.8,
    "link_beams": 256.5,
    "tool_mount": 25.4,
    "gear_play": 118.7,
    "approach_play": 101.4,
    "knee_joints": 571.6,
    "los_jumps": 147.9,
    "thermal_drift": 16.1,
    "tracker_scale": 0.064,
    "load_rehang": 11.3,
    "random_field": 40.7,
}
"""RMS change (μm) of the deflections at the default magnitude on Table III × 3 repeats, cell's truth,
no noise, seed 0: the amounts ``docs/twin.md`` documents."""


def _exact(cell, plan, effect=None, magnitude=1.0, seed=0):
    generator = IndependentGenerator(cell, np.random.default_rng(seed), truth="config", noise=False)
    return generator.simulate(plan, 3, effect, magnitude)


@pytest.fixture(scope="module")
def null(cell, plan):
    return _exact(cell, plan)[0]


def test_spring_moment_is_eq_7(cell):
    c = cell.compensator
    linkage = SpringLinkage(1, c.L, c.a_x, c.a_y, c.phi, c.K_c, c.s0)
    for angle in np.linspace(-2.5, 0.0, 7):
        assert linkage.moment(angle) == pytest.approx(c.torque(angle), rel=1e-12)


def test_null_campaign_agrees_with_the_package_model(cell, plan, null):
    arm = ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, compensated_joint=cell.compensated_joint, load_point=cell.load_point)
    markers = np.array(list(cell.markers.values()))
    for number, (q, mass) in enumerate(zip(plan.q, plan.masses(cell.load_mass))):
        unloaded = cell.robot.point_position(q + arm.equilibrium(q, np.zeros(6)), markers)
        loaded = cell.robot.point_position(q + arm.equilibrium(q, cell.load_wrench(q, mass)), markers)
        rows = null.config == number + 1
        np.testing.assert_allclose(null.displacement[rows], np.tile(loaded - unloaded, (3, 1)), atol=1e-9)
    # 1 nm against a tracker noise of tens of μm.
    assert cell.tracker.sigma(null.p0).min() > 1e4 * 1e-9


def test_campaign_has_the_plan_and_the_load_point(cell, plan, null):
    assert len(null) == 3 * len(plan) * len(cell.markers)
    assert list(null.repeat[:9]) == [1, 1, 1, 2, 2, 2, 3, 3, 3]
    np.testing.assert_allclose(null.q[::9], plan.q)
    np.testing.assert_allclose(null.wrench[0], cell.load_wrench(plan.q[0], plan.load_kg[0]), atol=1e-9)
    np.testing.assert_allclose(null.load_point, np.tile(cell.load_point, (len(null), 1)))


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_each_effect_changes_the_data_by_its_documented_amount(cell, plan, null, name):
    campaign, truth = _exact(cell, plan, name)
    change = np.sqrt(np.mean((campaign.displacement - null.displacement) ** 2)) / 1e-6
    assert change == pytest.approx(CHANGE_UM[name], rel=0.01)
    assert truth.effect == name and truth.cause in (*CAUSES, None)
    assert truth.expected == (truth.cause or "unexplained")


@pytest.mark.parametrize("name", ["link_beams", "tool_mount", "approach_play", "knee_joints", "tracker_scale", "random_field"])
def test_proportional_effects_double_with_the_magnitude(cell, plan, null, name):
    changes = [np.sqrt(np.mean((_exact(cell, plan, name, m)[0].displacement - null.displacement) ** 2)) for m in (1.0, 2.0)]
    assert changes[1] / changes[0] == pytest.approx(2.0, rel=0.02)


def test_gear_play_moves_only_when_the_torque_crosses(cell):
    play = GearPlay(np.full(2, 2e-4), np.full(2, 30.0), np.full(2, 10.0))
    position = play.update(np.zeros(2), np.array([500.0, -500.0]))
    np.testing.assert_allclose(position, [1e-4, -1e-4], rtol=1e-9)
    # A torque within the friction band leaves the play where it was; one past it the other way turns it over.
    np.testing.assert_array_equal(play.update(position, np.array([-20.0, 20.0])), position)
    np.testing.assert_allclose(play.update(position, np.array([-500.0, 500.0])), [-1e-4, 1e-4], rtol=1e-9)


def test_approach_play_keeps_the_side_it_was_driven_to_below_the_hold():
    play = ApproachPlay(np.array([2e-4, 4e-4, 6e-4]), np.array([30.0, 30.0, 30.0]), np.zeros(3))
    np.testing.assert_allclose(play.start(), [-1e-4, -2e-4, -3e-4])
    # Joint 1 driven up lags on its lower flank, joint 2 driven down on its upper one, joint 3 not moved keeps its side.
    arrived = play.arrive(np.array([0.0, 0.0, 3e-4]), np.zeros(3), np.array([0.2, -0.1, 0.0]))
    np.testing.assert_allclose(arrived, [-1e-4, 2e-4, 3e-4])
    # Torques below the hold, either way, leave every link on its flank.
    np.testing.assert_array_equal(play.update(arrived, np.array([29.0, -29.0, -29.0])), arrived)
    # Past the hold the link crosses to the far flank and stays there once the torque falls back.
    crossed = play.update(arrived, np.array([31.0, -31.0, -31.0]))
    np.testing.assert_allclose(crossed, [1e-4, -2e-4, -3e-4])
    np.testing.assert_array_equal(play.update(crossed, np.zeros(3)), crossed)


def test_approach_play_depends_on_the_order_of_the_configurations(cell, plan, null):
    reversed_plan = replace(plan, q=plan.q[::-1], load_kg=plan.load_kg[::-1], lines=plan.lines[::-1])
    runs = [_exact(cell, p, "approach_play")[0] for p in (plan, reversed_plan)]
    forward, backward = (c.displacement.reshape(len(plan), -1) for c in runs)
    changed = np.abs(forward - backward[::-1]).max(axis=1)
    # The same configurations, approached from other neighbours, take up other sides of the play.
    assert changed.max() > 1e-6
    assert np.abs(forward - null.displacement.reshape(len(plan), -1)).max() > 1e-6


def test_approach_play_of_size_zero_is_the_effect_free_campaign(cell):
    rng = np.random.default_rng(9)
    plan = random_plan(cell, rng)
    runs = [
        IndependentGenerator(cell, np.random.default_rng(3), noise=False).simulate(plan, 3, effect, magnitude)[0]
        for effect, magnitude in ((None, 1.0), ("approach_play", 0.0), ("approach_play", 1.0))
    ]
    np.testing.assert_array_equal(runs[1].p1, runs[0].p1)
    np.testing.assert_array_equal(runs[1].p0, runs[0].p0)
    assert np.abs(runs[2].displacement - runs[0].displacement).max() > 1e-6


def test_cantilever_is_euler_bernoulli_and_reciprocal():
    section = BeamSection(EA=3e9, EI=2e7, GJ=3e7)
    ell = 1.2
    tip = cantilever_twist(ell, section, [0, 0, 1000.0], [0, 0, 0], [0, 0, 0])
    assert tip[2] == pytest.approx(1000.0 * ell**3 / (3 * 2e7))
    # Maxwell-Betti: the compliance matrix of the tip is symmetric.
    columns = [cantilever_twist(ell, section, np.eye(6)[i, :3], np.eye(6)[i, 3:], np.zeros(3)) for i in range(6)]
    compliance = np.array(columns).T
    np.testing.assert_allclose(compliance, compliance.T, atol=1e-15)


def test_anisotropic_noise_keeps_the_cells_scale(cell):
    rng = np.random.default_rng(3)
    points = np.tile([[2.4, 0.3, 1.2]], (40000, 1))
    readout = TrackerReadout(cell.tracker)
    errors = readout.read(points, rng) - points
    sigma = cell.tracker.sigma(points[:1])[0]
    assert np.sqrt(np.mean(errors**2)) == pytest.approx(sigma, rel=0.02)
    sight = (points[0] - cell.tracker.position) / np.linalg.norm(points[0] - cell.tracker.position)
    radial = errors @ sight
    transverse = np.sqrt((np.sum(errors**2, axis=1) - radial**2).mean() / 2.0)
    assert radial.std() / transverse == pytest.approx(RADIAL_RATIO, rel=0.03)


@pytest.mark.parametrize(("effect", "repeats", "seeds"), [("thermal_drift", 2, (4, 4, 5)), ("approach_play", 3, (6, 6, 7))])
def test_seeds_reproduce_exactly(cell, tmp_path, effect, repeats, seeds):
    paths = []
    for index, seed in enumerate(seeds):
        rng = np.random.default_rng(seed)
        campaign, _ = IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), repeats, effect)
        paths.append(tmp_path / f"{index}.csv")
        write_campaign(campaign, paths[-1])
    assert paths[0].read_bytes() == paths[1].read_bytes() != paths[2].read_bytes()


def test_random_plan_is_feasible(cell):
    plan = random_plan(cell, np.random.default_rng(8))
    assert plan.q.shape == (30, cell.robot.nq) and len(np.unique(plan.q[:, 1])) == 6
    assert np.all((plan.load_kg >= 200) & (plan.load_kg <= 300))
    for q in plan.q:
        cell.robot.check_limits(q)


def test_drawn_truth_is_not_the_config(cell):
    _, truth = IndependentGenerator(cell, np.random.default_rng(2)).simulate(random_plan(cell, np.random.default_rng(2)), 1)
    table = truth.summary()
    assert not np.allclose(truth.world.compliances, cell.compliances)
    assert np.linalg.norm(truth.world.load_point - cell.load_point) > 1e-3
    assert table.loc["K_c", "unit"] == "N/mm" and json.loads(truth.to_json())["expected"] == "adequate"


def test_unknown_effect_is_an_input_error(cell, plan):
    with pytest.raises(InputError, match="unknown effect"):
        IndependentGenerator(cell, np.random.default_rng(0)).simulate(plan, 1, "wobble")
    with pytest.raises(InputError, match="magnitude"):
        IndependentGenerator(cell, np.random.default_rng(0)).simulate(plan, 1, "link_beams", -1.0)


def test_spring_effect_needs_a_compensator(cell, plan):
    plain = replace(cell, compensator=None)
    with pytest.raises(InputError, match="no compensator"):
        IndependentGenerator(plain, np.random.default_rng(0)).simulate(plan, 1, "stiff_spring")
    campaign, _ = IndependentGenerator(plain, np.random.default_rng(0)).simulate(plan, 1, "link_beams")
    assert np.all(np.isfinite(campaign.p1))


def _calibrates(cell, data_dir, tmp_path, name):
    rng = np.random.default_rng(11)
    campaign, _ = IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), 3, name)
    path = tmp_path / "campaign.csv"
    write_campaign(campaign, path)
    assert len(read_campaign(path, cell=cell)) == len(campaign)
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        status = main(["calibrate", str(path), "--config", str(data_dir / "kr270.toml"), "--json", "--draws", "100"])
    assert status == 0
    assert json.loads(out.getvalue())["diagnostics"]["chi2_per_dof"] > 0.5


def test_an_effect_campaign_calibrates(cell, data_dir, tmp_path):
    _calibrates(cell, data_dir, tmp_path, "gear_play")


@pytest.mark.slow
@pytest.mark.parametrize("name", [None, *sorted(EFFECTS)])
def test_every_effect_campaign_calibrates(cell, data_dir, tmp_path, name):
    _calibrates(cell, data_dir, tmp_path, name)


THREE_JOINTS = """<robot name="three">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0.6"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="4000" velocity="1"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 0"/><mass value="80"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.2 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="0.5" effort="4000" velocity="1"/></joint>
  <link name="l2"><inertial><origin xyz="0.45 0 0"/><mass value="60"/><inertia ixx="1" ixy="0" ixz="0" iyy="5" iyz="0" izz="5"/></inertial></link>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/><origin xyz="0.9 0 0"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="2000" velocity="1"/></joint>
  <link name="l3"><inertial><origin xyz="0.4 0 0"/><mass value="30"/><inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="2"/></inertial></link>
  <joint name="tip" type="fixed"><parent link="l3"/><child link="flange"/><origin xyz="0.8 0 0"/></joint>
  <link name="flange"/>
</robot>"""


def test_another_robot_without_compensator(cell, tmp_path):
    from bayescal.cell.plan import Plan
    from bayescal.robot.kinematics import Robot
    from bayescal.twin.independent.solver import Load, Statics, scaled_robot

    (tmp_path / "three.urdf").write_text(THREE_JOINTS)
    robot = Robot.from_urdf(tmp_path / "three.urdf")
    k = np.array([2e-6, 1e-6, 3e-6])
    # Weightless links and a small load: the deflection is the linear compliance J k Jᵀ f.
    statics = Statics(scaled_robot(robot, 0.0), lambda torque: k * torque)
    angles, point, force = np.array([0.3, -0.6, 0.9]), np.array([0.1, 0.0, 0.2]), np.array([3.0, -2.0, -5.0])
    theta, _ = statics.solve(angles, [Load(force, point)])
    jacobian = robot.point_jacobian(angles, point)
    moved = robot.point_position(angles + theta, point) - robot.point_position(angles, point)
    np.testing.assert_allclose(moved, jacobian @ (k * (jacobian.T @ force)), rtol=1e-4)
    # The generator runs on it with the links' weights and each structural effect changes its data.
    small = replace(cell, robot=robot, compliances=k, compensator=None)
    plan = Plan(np.array([[0.3, -0.6, 0.9], [-0.4, -1.2, 0.4]]), np.array([40.0, 60.0]), np.zeros(2, dtype=int))
    campaign, _ = IndependentGenerator(small, np.random.default_rng(0), truth="config", noise=False).simulate(plan, 1)
    for name in ("link_beams", "knee_joints", "gear_play"):
        changed, _ = IndependentGenerator(small, np.random.default_rng(0), truth="config", noise=False).simulate(plan, 1, name)
        assert np.abs(changed.displacement - campaign.displacement).max() > 1e-6


def test_repeats_agree_unless_the_load_is_rehung(cell, plan, null):
    rehung, _ = _exact(cell, plan, "load_rehang")
    spread = [np.ptp(c.displacement.reshape(-1, 3, 3, 3), axis=1).max() for c in (null, rehung)]
    # Without noise the repeats of a configuration see the same deflection, to rounding; re-hanging the load does not.
    assert spread[0] < 1e-12 and spread[1] > 5e-6


def test_drift_grows_with_the_time_of_the_reading(cell, plan, null):
    drifted, _ = _exact(cell, plan, "thermal_drift")
    shift = np.linalg.norm(drifted.p0 - null.p0, axis=1)
    # 0.2 mm/h over a 9 h campaign: the last configuration's readings moved far more than the first's.
    assert shift[-9:].mean() > 5 * shift[:9].mean() and shift.max() > 0.3e-3


def test_isotropic_option_is_the_cells_model(cell):
    points = np.tile([[2.4, 0.3, 1.2]], (40000, 1))
    errors = TrackerReadout(cell.tracker, isotropic=True).read(points, np.random.default_rng(4)) - points
    np.testing.assert_allclose(errors.std(axis=0), cell.tracker.sigma(points[:1])[0], rtol=0.02)
