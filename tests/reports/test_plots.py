import numpy as np
import pandas as pd

from bayescal.robot.compensator import Compensator
from bayescal.geometry.arcs import CompensatorGeometryModel, read_arc_points
from bayescal.reports.plots import plot_arc_fit, plot_eta_curves
from bayescal.units import DEG, MM


def test_eta_curves_plot_eq_9_for_each_s0(tmp_path, data_dir):
    points = read_arc_points(data_dir / "table1_geometry.csv")
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


def test_arc_fit_figure_shows_points_and_residuals(tmp_path, data_dir):
    points = read_arc_points(data_dir / "table1_geometry.csv")
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


def test_joint2_compliance_figure_has_band_points_and_lines(tmp_path):
    from bayescal.reports.plots import plot_joint2_compliance

    q2_deg = np.linspace(-140, 0, 30)
    band = pd.DataFrame(
        {"low_urad_per_Nm": 0.294, "median_urad_per_Nm": 0.3, "high_urad_per_Nm": 0.306, "truth_urad_per_Nm": 0.3},
        index=pd.Index(q2_deg, name="q2_deg"),
    )
    angles = np.array([-140.0, -60.0, 0.0]) * DEG
    figure = plot_joint2_compliance(band, angles, np.full(3, 0.3e-6), np.full(3, 1e-9), own=0.302e-6)
    ax = figure.axes[0]
    assert len(ax.collections) >= 2  # the band and the error bars
    low, high = ax.get_ylim()
    assert low < 0.295 < 0.305 < high  # μrad/(N·m): the data are drawn in the paper's unit
    labels = [text.get_text() for text in ax.get_legend().get_texts()]
    assert "truth" in labels and any("without compensator" in label for label in labels)
    figure.savefig(tmp_path / "joint2.png")
    assert (tmp_path / "joint2.png").stat().st_size > 1000
