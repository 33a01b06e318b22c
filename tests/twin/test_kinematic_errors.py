"""Kinematic errors of the twin and of the independent generator, in the kinematic calibration's parameters."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.kinematics.cell import load_points_cell
from bayescal.kinematics.model import PointModel
from bayescal_studies.studies.kinematic_worlds import placement_corrections
from bayescal.twin.independent.geometry import GeometryErrors
from bayescal.twin.kinematic_errors import COMPONENTS, KinematicErrors, with_kinematic_errors
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def cell(data_dir):
    return load_cell(data_dir / "kr270.toml")


@pytest.fixture(scope="module")
def points(data_dir):
    return load_points_cell(data_dir / "robots" / "kr270_points.toml")


@pytest.fixture(scope="module")
def q(cell):
    rng = np.random.default_rng(3)
    return rng.uniform(0.8 * cell.robot.lower, 0.8 * cell.robot.upper, (20, cell.robot.nq))


def _rigid(points, q, corrections: np.ndarray) -> np.ndarray:
    """The geometry rung's markers with each joint's correction set to ``corrections`` (nq, 6), all else nominal."""
    model = PointModel(points, "geometry")
    theta = model.mean.copy()
    for j, row in enumerate(corrections, start=1):
        for c, value in zip(COMPONENTS, row):
            theta[model.names.index(f"{points.tree.names[j]}.{c}")] = value
    return model.predict(theta, q, jacobian=False)[0]


def _markers(robot, points, q, cell) -> np.ndarray:
    return np.array([[robot.point_position(qi, cell.markers[name]) for name in points.marker_names] for qi in q])


def test_the_twins_errors_are_the_calibrations_own_parameters(cell, points, q):
    errors = KinematicErrors.draw(cell.robot, np.random.default_rng(1))
    true = _markers(errors.apply(cell.robot), points, q, cell)
    assert np.abs(_rigid(points, q, errors.deltas) - true).max() < 1e-12
    # Of realistic size: the markers move by millimetres, not by microns or centimetres.
    moved = np.linalg.norm(true - _markers(cell.robot, points, q, cell), axis=-1)
    assert 0.5e-3 < moved.max() < 20e-3


def test_the_independent_dh_errors_are_read_off_the_placements_exactly(cell, points, q):
    robot = GeometryErrors.draw(cell.robot.nq, np.random.default_rng(2)).robot(cell.robot)
    corrections = placement_corrections(cell.robot.model, robot.model)
    assert np.abs(_rigid(points, q, corrections) - _markers(robot, points, q, cell)).max() < 1e-12


def test_errors_of_size_zero_leave_the_twin_unchanged(cell):
    plan_q = np.array([[0.3, -0.8, 0.6, 0.2, -0.4, 0.5]])
    nominal = DigitalTwin(cell).positions(plan_q[0], 265.0)
    zero = DigitalTwin(with_kinematic_errors(cell, KinematicErrors.draw(cell.robot, np.random.default_rng(4), scale=0.0)))
    assert all(np.array_equal(a, b) for a, b in zip(nominal, zero.positions(plan_q[0], 265.0)))


def test_a_negative_scale_is_refused(cell):
    with pytest.raises(ValueError, match="scale"):
        KinematicErrors.draw(cell.robot, np.random.default_rng(0), scale=-1.0)
