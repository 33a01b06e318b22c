"""What the twin's truth is at the test pose: the deflection a perfect calibration would predict."""

from __future__ import annotations

import numpy as np

from bayescal.cell.config import Cell
from bayescal.robot.stiffness import equilibrium

__all__ = ["true_test_deflection"]


def true_test_deflection(cell: Cell) -> np.ndarray:
    """``(3,)`` deflection (m, base axes) of the tool point at the cell's test pose under its test wrench.

    The static equilibria with and without the wrench, both under the arm's
    weight and the compensator, with the cell's own compliances: the truth a
    posterior prediction of the twin's test pose is judged against.
    """
    robot, q = cell.robot, cell.test_q
    common = {"compensator": cell.compensator, "load_point": cell.test_point}
    loaded = q + equilibrium(robot, q, cell.compliances, cell.test_wrench, **common)
    unloaded = q + equilibrium(robot, q, cell.compliances, np.zeros(6), **common)
    return robot.point_position(loaded, cell.test_point) - robot.point_position(unloaded, cell.test_point)
