"""Tests of bayescal.design.linearisation.test_deflection: a cell's true deflection at its test pose."""

from __future__ import annotations

import dataclasses

import numpy as np

from bayescal.design.linearisation import test_deflection
from bayescal.units import MM


def test_true_deflection_grows_with_the_test_wrench(cell):
    deflection = test_deflection(cell)
    assert deflection.shape == (3,)
    assert 0.1 * MM < np.linalg.norm(deflection) < 10 * MM
    # no wrench, no deflection: the arm's own sag is in both equilibria
    assert np.allclose(test_deflection(dataclasses.replace(cell, test_wrench=np.zeros(6))), 0.0)
    # the joints are linear springs, so a small wrench gives a proportionally small deflection
    tenth = test_deflection(dataclasses.replace(cell, test_wrench=0.1 * cell.test_wrench))
    np.testing.assert_allclose(tenth, 0.1 * deflection, rtol=0.02, atol=1e-9)
