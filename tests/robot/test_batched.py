"""The batched chain against Pinocchio and the one-configuration solver, on the KR-270 and the project's test robots."""

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.stiffness import ElasticArm, EquilibriumError
from bayescal_studies.studies.elastostatic_coverage import random_plan

CELLS = ("kr270.toml", "robots/arm7.toml", "robots/arm6.toml", "robots/arm6_j3.toml", "robots/track_arm6.toml")


@pytest.fixture(scope="module", params=CELLS)
def setting(request, data_dir):
    cell = load_cell(data_dir / request.param)
    rng = np.random.default_rng(7)
    return cell, random_plan(cell, 4, 2, rng).q, rng


def test_kinematics_gravity_and_load_hessian_equal_pinocchio(setting):
    cell, q, rng = setting
    chain = BatchedChain.of(cell.robot)
    poses = chain.poses(q)
    point = np.array([0.12, -0.2, 0.31])
    load = rng.normal(size=(len(q), 6)) * [1e3, 1e3, 1e3, 1e2, 1e2, 1e2]
    at = poses.points(point)
    linear, angular = chain.point_jacobian(poses, at)
    torque, derivative = chain.load_torque(poses, at, load)
    weight, weight_derivative = chain.gravity_torque(poses)
    workspace = cell.robot.workspace()
    for i, qi in enumerate(q):
        rotation, origin = workspace.flange_pose(qi)
        np.testing.assert_allclose(poses.flange_rotation[i], rotation, atol=1e-14)
        np.testing.assert_allclose(poses.flange_origin[i], origin, atol=1e-14)
        np.testing.assert_allclose(poses.in_flange(at)[i], point, atol=1e-14)
        np.testing.assert_allclose(linear[i].T, workspace.point_jacobian(qi, point), atol=1e-14)
        np.testing.assert_allclose(angular[i].T, workspace.flange_jacobian(qi)[3:], atol=1e-14)
        jacobian = np.vstack([workspace.point_jacobian(qi, point), workspace.flange_jacobian(qi)[3:]])
        np.testing.assert_allclose(torque[i], jacobian.T @ load[i], rtol=1e-12, atol=1e-9)
        hessian = np.einsum("r,rij->ij", load[i], workspace.point_hessian(qi, point))
        np.testing.assert_allclose(derivative[i], hessian, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(weight[i], workspace.gravity_torque(qi), rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(weight_derivative[i], workspace.gravity_torque_derivative(qi), rtol=1e-12, atol=1e-9)


def test_equilibria_equal_the_one_configuration_solver(setting):
    cell, q, rng = setting
    point = np.array([0.05, 0.1, 0.4])
    wrench = np.column_stack([rng.normal(size=(len(q), 3)) * 2e3, rng.normal(size=(len(q), 3)) * 50])
    # Stiffer and softer joints than the cell's, one set per configuration.
    compliances = np.asarray(cell.compliances) * rng.uniform(0.5, 2.0, (len(q), cell.robot.nq))
    options = dict(compensator=cell.compensator, compensated_joint=cell.compensated_joint if cell.compensator else None, load_point=point)
    theta = equilibria(BatchedChain.of(cell.robot), q, wrench, compliances, **options)
    for i, qi in enumerate(q):
        expected = ElasticArm.linear(cell.robot, compliances[i], **options).equilibrium(qi, wrench[i])
        np.testing.assert_allclose(theta[i], expected, rtol=0, atol=1e-15)
    assert np.abs(theta).max() > 1e-4


def test_equilibria_without_gravity_vanish_without_load(setting):
    cell, q, _ = setting
    theta = equilibria(BatchedChain.of(cell.robot), q, np.zeros(6), cell.compliances, gravity=False)
    assert np.all(theta == 0.0)


def test_an_unsettled_solve_names_its_configuration(setting):
    cell, q, _ = setting
    with pytest.raises(EquilibriumError, match=f"for some of {len(q)} configurations .the first: 0"):
        equilibria(BatchedChain.of(cell.robot), q, np.zeros(6), cell.compliances, max_iter=1)



def test_chunks_give_the_same_equilibria(setting, monkeypatch):
    from bayescal.robot import batched

    cell, q, _ = setting
    options = dict(compensator=cell.compensator, compensated_joint=cell.compensated_joint if cell.compensator else None)
    whole = equilibria(BatchedChain.of(cell.robot), q, [0.0, 0.0, -2500.0, 0.0, 0.0, 0.0], cell.compliances, **options)
    monkeypatch.setattr(batched, "CHUNK", 3)
    chunked = equilibria(BatchedChain.of(cell.robot), q, [0.0, 0.0, -2500.0, 0.0, 0.0, 0.0], cell.compliances, **options)
    np.testing.assert_array_equal(chunked, whole)


def test_soft_springs_that_make_newton_backtrack_give_the_loops_equilibria(cell):
    # Springs 160 times the cell's under 2,700 N: the full Newton step overshoots for some configurations.
    q = random_plan(cell, 60, 1, np.random.default_rng(0)).q
    compliances = 160 * np.asarray(cell.compliances)
    options = dict(compensator=cell.compensator, compensated_joint=cell.compensated_joint, load_point=cell.load_point)
    wrench = np.array([0.0, 0.0, -2700.0, 0.0, 0.0, 0.0])
    theta = equilibria(BatchedChain.of(cell.robot), q, wrench, compliances, **options)
    arm = ElasticArm.linear(cell.robot, compliances, **options)
    expected = np.array([arm.equilibrium(qi, wrench) for qi in q])
    np.testing.assert_allclose(theta, expected, rtol=0, atol=1e-14)
    assert np.abs(theta).max() > 0.1


@pytest.mark.parametrize("name", ["kr270.toml", "robots/arm6_j3.toml", "robots/track_arm6.toml"])
def test_equilibria_equal_the_independent_generators_solver(data_dir, name):
    # bayescal.twin.independent.solver: Pinocchio's kinematics, its own spring linkage, a derivative-free root finder.
    from bayescal.twin.independent.solver import Load, SpringLinkage, Statics

    cell = load_cell(data_dir / name)
    rng = np.random.default_rng(5)
    q = random_plan(cell, 3, 2, rng).q
    compliances = np.asarray(cell.compliances)
    force, couple, point = np.array([300.0, -200.0, -2500.0]), np.array([40.0, -25.0, 10.0]), np.array([0.05, -0.1, 0.35])
    c = cell.compensator
    linkage = None if c is None else SpringLinkage(cell.compensated_joint, c.L, c.a_x, c.a_y, c.phi, c.K_c, c.s0)
    statics = Statics(cell.robot, lambda torque: compliances * torque, linkage)
    chain = BatchedChain.of(cell.robot)
    # The wrench at the flange origin whose force acts at the point, as applied at the commanded pose.
    lever = np.einsum("nij,j->ni", chain.poses(q).flange_rotation, point)
    wrench = np.column_stack([np.broadcast_to(force, (len(q), 3)), couple + np.cross(lever, force)])
    options = dict(compensator=c, compensated_joint=cell.compensated_joint if c else None, load_point=point)
    theta = equilibria(chain, q, wrench, compliances, **options)
    for i, qi in enumerate(q):
        expected, _ = statics.solve(qi, [Load(force=force, point=point, couple=couple)])
        np.testing.assert_allclose(theta[i], expected, rtol=0, atol=1e-11)


def test_poses_of_more_configurations_than_a_chunk_equal_each_chunks_bit_for_bit(setting):
    from dataclasses import fields

    from bayescal.robot.batched import CHUNK

    cell = setting[0]
    chain = BatchedChain.of(cell.robot)
    q = np.random.default_rng(3).uniform(cell.robot.lower, cell.robot.upper, size=(2 * CHUNK + 5, cell.robot.nq))
    whole = chain.poses(q)
    for start in (0, CHUNK, 2 * CHUNK):
        alone = chain.poses(q[start : start + CHUNK])
        for field in fields(alone):
            assert np.array_equal(getattr(whole, field.name)[start : start + CHUNK], getattr(alone, field.name)), field.name
