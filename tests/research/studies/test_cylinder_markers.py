"""Tests of bayescal_studies.studies.cylinder_markers: what each cylinder marker of Table I says about p0."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from bayescal.geometry.arcs import CompensatorGeometryModel
from bayescal.twin.arcs import simulate_markers
from bayescal_studies.studies.cylinder_markers import along_arc_residuals, cylinder_marker_study, implied_cylinder_noise
from bayescal.units import DEG, MM


def test_each_marker_alone_fixes_p0_poorly_on_table_i(table1):
    points, closed = table1
    study = cylinder_marker_study(points, closed)
    assert list(study.index) == points.cylinder_markers
    # the markers' own centres disagree by several mm, the shared one lies between them
    assert study["a_y_alone_mm"].max() - study["a_y_alone_mm"].min() > 3.0
    assert study["a_y_alone_mm"].min() < closed.geometry.a_y / MM < study["a_y_alone_mm"].max()
    # both markers' residuals run the same way with q2, and neither is rigid on the cylinder
    assert (study["residual_correlation"] > 0.5).all()
    assert (study["drift_along_arc_mm"] > 5 * closed.residuals_rms["P1"] / MM).all()
    assert study["drift_along_arc_mm"].to_numpy() == pytest.approx(
        (study["drift_deg"] * DEG * pd.Series(closed.cylinder.radii) / MM).to_numpy()
    )


def test_markers_rigid_on_the_cylinder_do_not_drift(layout, q2):
    exact = simulate_markers(layout, q2, np.random.default_rng(0), sigma=0.0)
    study = cylinder_marker_study(exact, CompensatorGeometryModel().fit(exact))
    assert study["drift_deg"].to_numpy() == pytest.approx(0.0, abs=1e-6)
    assert study["residual_rms_mm"].to_numpy() == pytest.approx(0.0, abs=1e-6)


def test_along_arc_residuals_keep_the_tangential_part(table1):
    points, closed = table1
    name = points.cylinder_markers[0]
    _, xyz = points.of(name)
    radial = xyz[:, :2] - closed.p0[:2]
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    tangent = np.column_stack([-radial[:, 1], radial[:, 0]])
    residual = 2.0 * tangent + 3.0 * radial
    np.testing.assert_allclose(along_arc_residuals(points, closed.p0[:2], name, residual), 2.0)


def test_implied_noise_scales_the_cylinder_sd_to_the_published_width():
    summary = pd.DataFrame({"mean": [0.2, 686.0, 119.0], "sd": [0.06, 0.8, 0.4]}, index=["sigma[cylinder]", "a_x", "a_y"])
    published = pd.DataFrame({"published_half_width_3sd": [0.6, 1.2]}, index=["a_x", "a_y"])
    implied = implied_cylinder_noise(summary, published)
    assert implied["a_x"] == pytest.approx(0.2 * 0.2 / 0.8)
    assert implied["a_y"] == pytest.approx(0.2 * 0.4 / 0.4)
