"""Loads in any direction against hanging masses (studies.load_directions)."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal_studies.studies.load_directions import load_direction_study, sideways


@pytest.fixture(scope="module")
def any_cell(data_dir):
    return load_cell(data_dir / "kr270_any_load.toml")


def test_sideways_turns_the_farthest_loads_across_the_radius(any_cell, plan):
    turned = sideways(any_cell, plan, 3)
    forces = turned.forces(any_cell.load_mass, any_cell.gravity)
    np.testing.assert_allclose(np.linalg.norm(forces, axis=1), plan.load_kg * any_cell.gravity)
    horizontal = np.flatnonzero(np.abs(forces[:, 2]) < 1e-9)
    assert horizontal.size == 3
    for row in horizontal:
        point = any_cell.robot.point_position(plan.q[row], any_cell.load_point)
        assert abs(forces[row, :2] @ point[:2]) < 1e-6 * np.linalg.norm(point[:2]) * 3000  # across the radius


def test_a_small_study_reports_k1_and_the_test_pose_error(any_cell, tmp_path):
    findings = load_direction_study(
        any_cell, angles=3, per_angle=2, campaigns=6, candidates_per_angle=2, starts=1, model="linear", executor=ThreadPoolExecutor(2)
    )
    scores = findings.summary()
    assert list(scores.index) == ["hanging, test-pose optimal", "hanging + 3 sideways", "free directions, test-pose optimal"]
    assert list(scores["k1_identifiable"]) == [False, True, True]
    assert list(scores["k1_excited"]) == [False, True, True]
    assert np.isnan(scores["k1_coverage_3sd"].iloc[0]) and scores["k1_coverage_3sd"].iloc[1:].between(0, 1).all()
    assert (scores["mean_error_um"] > 0).all() and scores["difference_to_hanging_um"].iloc[0] == 0
    findings.save(tmp_path / "findings.json")
    payload = json.loads((tmp_path / "findings.json").read_text())
    assert payload["settings"]["campaigns"] == 6 and "gain_in_se" in payload["diagnostics"]


def test_a_hanging_only_cell_is_refused(cell):
    with pytest.raises(ValueError, match="any direction"):
        load_direction_study(cell, campaigns=2)


@pytest.mark.slow
def test_free_directions_beat_the_best_hanging_plan_over_200_campaigns(any_cell):
    findings = load_direction_study(any_cell, campaigns=200)
    scores = findings.summary()
    free = scores.loc["free directions, test-pose optimal"]
    assert free["k1_identifiable"] and free["k1_coverage_3sd"] >= 0.98
    # the paired difference of the mean error left at the test pose, in its standard errors
    assert free["difference_to_hanging_um"] < -3.0 * free["difference_se_um"]
    assert scores.loc["hanging + 3 sideways", "k1_identifiable"]
