"""What the twin's truth is at the test pose: the deflection a perfect calibration would predict."""

from __future__ import annotations

import numpy as np

from bayescal.cell.config import Cell
from bayescal.inference.exact import exact_deflections

__all__ = ["true_test_deflection"]


def true_test_deflection(cell: Cell) -> np.ndarray:
    """``(3,)`` deflection (m, base axes) of the tool point at the cell's test pose under its test wrench.

    The static equilibria with and without the wrench, both under the arm's
    weight and the compensator, with the cell's own compliances: the truth a
    posterior prediction of the twin's test pose is judged against.
    """
    point = np.asarray(cell.test_point, dtype=float).reshape(1, 3)
    return exact_deflections(
        cell.robot, cell.test_q, cell.test_wrench, cell.compliances, cell.compensator, points_in_flange=point, load_point=cell.test_point,
        compensated_joint=cell.compensated_joint,
    )[0]
