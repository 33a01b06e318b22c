"""Tests of bayescal.compensation.spread: eq 31's matrices of many poses at once, and the draws through them."""

import numpy as np

from bayescal.compensation.spread import designs
from bayescal.robot.batched import BatchedChain
from bayescal.robot.stiffness import compliance_design
from bayescal_studies.studies.compensation import random_program


def test_the_batched_designs_are_pinocchios_pose_by_pose(cell):
    program = random_program(cell, 12, np.random.default_rng(4))
    chain = BatchedChain.of(cell.robot)
    wrench = program.flange_wrench(chain.poses(program.q).flange_rotation)
    batched = designs(chain, program.q, program.tcp, wrench)
    one_by_one = np.stack([compliance_design(cell.robot, q, tcp, w) for q, tcp, w in zip(program.q, program.tcp, wrench)])
    assert batched.shape == (12, 3, cell.robot.nq)
    # the same products in another order: equal to rounding, and far from zero
    np.testing.assert_allclose(batched, one_by_one, rtol=0, atol=1e-12 * np.abs(one_by_one).max())
    assert np.abs(one_by_one).max() > 1.0
