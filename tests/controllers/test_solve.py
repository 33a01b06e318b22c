"""Cartesian targets solved in the configuration they name, and the errors of those that cannot be."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.controllers import configuration as conf
from bayescal.controllers.compensate import program_joints
from bayescal.controllers.krl import read_krl
from bayescal.errors import InputError
from bayescal.robot.batched import BatchedChain
from bayescal.robot.inverse import inverse_kinematics, wrap_angles
from bayescal.units import DEG


def test_every_class_of_the_kr270_is_solved_back_to_its_joints(robot, drawn):
    q = drawn.q_deg * DEG
    poses = BatchedChain.of(robot).poses(q)
    status = conf.kuka_status(robot, q)
    assert np.array_equal(status, drawn.status) and np.array_equal(conf.kuka_turn(q), drawn.turn)
    assert np.array_equal(conf.abb_cfx(robot, q), drawn.cfx) and np.array_equal(conf.abb_quadrants(q), drawn.quadrants)
    assert len(np.unique(status)) >= 4
    solution = inverse_kinematics(robot, poses.flange_rotation, poses.flange_origin, status, lambda joints: conf.kuka_status(robot, joints))
    assert solution.kept.all()
    # Same status, same pose: the same joints up to whole turns (the turn bits pick those).
    assert np.abs(wrap_angles(robot, solution.q - q)).max() < 1e-7


def _krl(tmp_path, programs, drawn, **change):
    import copy

    changed = copy.deepcopy(drawn)
    for key, (index, value) in change.items():
        getattr(changed, key)[index] = value
    src, dat = programs.krl_texts(changed)
    (tmp_path / "p.src").write_text(src)
    (tmp_path / "p.dat").write_text(dat)
    return read_krl(tmp_path / "p.src")


def test_a_status_that_flips_the_arm_is_named(tmp_path, programs, drawn, robot):
    # Target 2 is reached in front of axis 1 only: status bit 0 (overhead) names no solution.
    program = _krl(tmp_path, programs, drawn, status=(1, drawn.status[1] ^ 1))
    with pytest.raises(InputError, match=rf"target XP2: S {drawn.status[1] ^ 1} does not reach it, S {drawn.status[1]} does: the arm would flip") as error:
        program_joints(program, robot)
    assert error.value.line == program.targets[2].line and error.value.source.endswith("p.dat")


def test_a_turn_the_solution_cannot_take_is_named(tmp_path, programs, drawn, robot):
    program = _krl(tmp_path, programs, drawn, turn=(0, drawn.turn[0] ^ 0b100))
    with pytest.raises(InputError, match="target XP1: axis 3 at .* cannot be turned to the side its turn T names"):
        program_joints(program, robot)


def test_a_target_out_of_reach_is_named(tmp_path, programs, drawn, robot):
    import pinocchio as pin

    far = pin.SE3(drawn.poses[0].rotation, drawn.poses[0].translation + np.array([5.0, 0.0, 0.0]))
    program = _krl(tmp_path, programs, drawn, poses=(0, far))
    with pytest.raises(InputError, match="target XP1: no joints put the tool within .* out of the robot's reach"):
        program_joints(program, robot)
