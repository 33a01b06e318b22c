"""Fixtures of the studies on simulated Table I campaigns: Table I's points, its closed-form fit and marker layout."""

import numpy as np
import pytest

from bayescal.geometry.arcs import LEVER_MARKER, CompensatorGeometryModel, MarkerLayout, read_arc_points


@pytest.fixture(scope="session")
def table1(data_dir):
    """Table I's marker points and their closed-form fit."""
    points = read_arc_points(data_dir / "table1_geometry.csv")
    return points, CompensatorGeometryModel().fit(points)


@pytest.fixture(scope="session")
def layout(table1):
    """The marker layout of Table I's closed-form fit: the truth of the simulated campaigns."""
    points, fit = table1
    return MarkerLayout.from_fit(fit, points)


@pytest.fixture(scope="session")
def q2(table1):
    """Table I's joint angles (rad), increasing."""
    points, _ = table1
    return np.sort(points.of(LEVER_MARKER)[0])
