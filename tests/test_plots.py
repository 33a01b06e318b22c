from pathlib import Path

import numpy as np

from bayescal.compensator import Compensator
from bayescal.geometry import CompensatorGeometryModel, read_arc_points
from bayescal.plots import plot_arc_fit, plot_eta_curves
from bayescal.units import DEG, MM

TABLE1 = Path(__file__).resolve().parents[1] / "data" / "table1_geometry.csv"


def test_eta_curves_plot_eq_9_for_each_s0(tmp_path):
    points = read_arc_points(TABLE1)
    geometry = CompensatorGeometryModel().fit(points).geometry
    s0_values = [0.0, 0.3, 0.458]
    figure = plot_eta_curves(geometry, s0_values, highlight=0.458)
    lines = figure.axes[0].get_lines()[: len(s0_values)]
    for line, s0 in zip(lines, s0_values):
        q2 = line.get_xdata() * DEG
        expected = Compensator(geometry.L, geometry.a_x, geometry.a_y, geometry.phi, 1.0, s0).eta(q2)
        np.testing.assert_allclose(line.get_ydata(), expected)
        assert line.get_label() == f"s0 = {s0 / MM:.0f} mm"
    assert lines[2].get_linewidth() > lines[0].get_linewidth()
    figure.savefig(tmp_path / "eta.png")
    assert (tmp_path / "eta.png").stat().st_size > 1000


def test_arc_fit_figure_shows_points_and_residuals(tmp_path):
    points = read_arc_points(TABLE1)
    fit = CompensatorGeometryModel().fit(points)
    extra = {"other": {name: np.zeros(6) for name in points.cylinder_markers}}
    figure = plot_arc_fit(points, fit, extra)
    overview, lever, cylinder = figure.axes
    p1 = [line for line in overview.get_lines() if line.get_label() == "P1"][0]
    np.testing.assert_allclose(np.sort(p1.get_xdata()), np.sort(points.of("P1")[1][:, 0] / MM))
    residual_x = [line for line in lever.get_lines() if line.get_label() == "P1 x"][0]
    order = np.argsort(points.of("P1")[0])
    np.testing.assert_allclose(residual_x.get_ydata(), fit.lever.residuals[order, 0] / 1e-6)
    labels = {line.get_label() for line in cylinder.get_lines()}
    assert {"P01 concentric (radial)", "P02 concentric (radial)", "P01 other", "P02 other"} <= labels
    figure.savefig(tmp_path / "arcs.png")
