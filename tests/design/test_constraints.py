"""Tests of bayescal.design.constraints: what a campaign configuration must satisfy."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayescal.design.constraints import DesignSpace, Feasibility, _segment_distance, load_design_space
from bayescal.errors import InputError


def test_the_cell_file_gives_the_papers_mass_range(cell):
    space = load_design_space(cell)
    assert space.mass_range == (250.0, 280.0)
    assert load_design_space(cell, mass_range=(100.0, 120.0)).mass_range == (100.0, 120.0)


def test_a_mass_range_of_zero_is_refused(cell):
    with pytest.raises(InputError, match="mass_range, column 'mass_kg': expected masses above 0 kg"):
        load_design_space(cell, mass_range=(0.0, 0.0))


def test_the_design_limits_come_from_the_cell(cell):
    limits = replace(cell.design, acceptance=math.radians(30.0), floor_z=0.2)
    space = load_design_space(replace(cell, design=limits))
    assert space.acceptance == pytest.approx(math.radians(30.0)) and space.floor_z == 0.2


def test_segment_distance_matches_a_dense_sampling():
    rng = np.random.default_rng(3)
    p0, p1 = rng.normal(size=3), rng.normal(size=3)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    t = np.linspace(0.0, 1.0, 801)
    line = p0 + t[:, None] * (p1 - p0)
    for i in range(5):
        other = a[i] + t[:, None] * (b[i] - a[i])
        brute = np.min(np.linalg.norm(line[:, None, :] - other[None, :, :], axis=-1))
        assert _segment_distance(p0, p1, a[i : i + 1], b[i : i + 1])[0] == pytest.approx(brute, abs=2e-3)


def test_each_constraint_is_reported(cell):
    feasibility = Feasibility(cell, load_design_space(cell))
    rng = np.random.default_rng(0)
    reasons = set()
    feasible = None
    for _ in range(400):
        q = rng.uniform(cell.robot.lower, cell.robot.upper)
        reason = feasibility.violation(q, 280.0)
        reasons.add("ok" if reason is None else reason.split(" ")[0] + " " + reason.split(" ")[-1])
        if reason is None:
            feasible = q
    assert {"ok", "marker tracker", "the floor"} <= reasons
    assert "outside the mass range" in feasibility.violation(feasible, 300.0)
    outside = feasible.copy()
    outside[1] = 0.1
    assert "outside its limits" in feasibility.violation(outside, 280.0)


def test_a_tracker_inside_the_base_sees_nothing(cell):
    hidden = replace(cell, tracker=replace(cell.tracker, position=np.array([0.0, 0.0, 0.3])))
    feasibility = Feasibility(hidden, DesignSpace((250.0, 280.0), acceptance=np.pi / 2))
    rng = np.random.default_rng(1)
    reasons = [feasibility.violation(rng.uniform(cell.robot.lower, cell.robot.upper), 280.0) for _ in range(100)]
    assert None not in reasons
    assert any("hides" in reason for reason in reasons)
