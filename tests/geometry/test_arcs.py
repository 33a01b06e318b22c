import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from bayescal.errors import InputError
from bayescal.geometry.arcs import (
    CompensatorGeometryModel,
    MarkerLayout,
    MarkerPoints,
    concentric_fit,
    known_angle_fit,
    read_arc_points,
)
from bayescal.reference import read_paper_reference
from bayescal.twin.arcs import simulate_markers
from bayescal.units import DEG, MM

Q2 = np.array([-0.01, -30, -60, -90, -120, -145]) * DEG


@pytest.fixture(scope="module")
def table1(data_dir):
    return read_arc_points(data_dir / "table1_geometry.csv")


@pytest.fixture(scope="module")
def table1_fit(table1):
    return CompensatorGeometryModel().fit(table1)


def test_table1_is_read_in_si(table1):
    assert table1.xyz.shape == (18, 2)
    assert table1.markers == ["P1", "P01", "P02"]
    q2, p1 = table1.of("P1")
    np.testing.assert_allclose(np.sort(q2), np.sort(Q2))
    # First P1 row of Table I: q2 = -0.01 deg, x = -31.84 mm, y = 183.86 mm.
    assert p1[np.argmax(q2)] == pytest.approx([-31.84 * MM, 183.86 * MM])
    assert table1.line[0] > 1  # comment lines and the header come first


def test_known_angle_fit_on_table1_is_a_reflection_with_the_paper_radius(table1_fit):
    lever = table1_fit.lever
    assert np.linalg.det(lever.R) == pytest.approx(-1.0)
    assert lever.sense == -1
    assert abs(lever.radius / MM - 184.72) < 0.03  # Klimchik et al., Table II
    # Table I puts the lever almost straight up with the arm horizontal.
    assert 95 < lever.phi / DEG < 105
    assert lever.rms < 0.1 * MM


def test_closed_form_a_x_is_inside_the_paper_interval(table1_fit, data_dir):
    reference = read_paper_reference(data_dir / "paper_reference.csv")
    a_x = table1_fit.geometry.a_x / MM
    assert abs(a_x - reference.loc["a_x", "value"]) <= reference.loc["a_x", "ci3"]
    assert table1_fit.mirrored is False
    # The spring is shortest with the arm vertical (q2 near -90 deg), as the gravity torque vanishes there.
    assert abs(table1_fit.geometry.alpha / DEG - 90) < 1


def test_summary_is_in_mm_and_deg(table1_fit):
    summary = table1_fit.summary()
    assert summary.loc["L", "unit"] == "mm"
    assert summary.loc["phi", "unit"] == "deg"
    assert {"R[P01]", "R[P02]", "rms[P1]", "rms[P01]", "rms[P02]"} <= set(summary.index)


def arc_points(q, radius, angle, sense, centre):
    lever = angle + sense * q
    return centre + radius * np.column_stack([np.cos(lever), np.sin(lever)])


def test_known_angle_fit_is_the_least_squares_solution():
    rng = np.random.default_rng(7)
    points = arc_points(Q2, 0.19, 1.2, -1, np.array([0.01, -0.02])) + 3e-4 * rng.standard_normal((6, 2))
    fit = known_angle_fit(Q2, points)

    def residuals(x):
        return (points - arc_points(Q2, x[0], x[1], fit.sense, x[2:])).ravel()

    solution = least_squares(residuals, np.r_[0.2, 1.0, 0.0, 0.0], xtol=1e-15, ftol=1e-15)
    assert fit.sense == -1
    assert fit.radius == pytest.approx(solution.x[0], rel=1e-9)
    assert fit.phi == pytest.approx(solution.x[1], abs=1e-9)
    np.testing.assert_allclose(fit.centre, solution.x[2:], atol=1e-10)
    np.testing.assert_allclose(fit.residuals.ravel(), solution.fun, atol=1e-10)


@pytest.mark.parametrize("sense", [1, -1])
def test_known_angle_fit_recovers_exact_arcs_of_either_sense(sense):
    centre, radius, phi = np.array([-0.4, 0.25]), 0.3, -2.0
    lever = phi + sense * Q2
    points = centre + radius * np.column_stack([np.cos(lever), np.sin(lever)])
    fit = known_angle_fit(Q2, points)
    assert fit.sense == sense
    assert fit.radius == pytest.approx(radius)
    assert fit.phi == pytest.approx(phi)
    np.testing.assert_allclose(fit.centre, centre, atol=1e-14)
    np.testing.assert_allclose(fit.predict(Q2), points, atol=1e-14)


def tilted_frame(tilt):
    # Orthonormal basis of a plane tilted about the x axis, and its normal.
    e1 = np.array([1.0, 0.0, 0.0])
    e2 = np.array([0.0, math.cos(tilt), math.sin(tilt)])
    return e1, e2, np.cross(e1, e2)


def test_known_angle_fit_in_3d_finds_the_plane_and_the_sense():
    e1, e2, normal = tilted_frame(0.2)
    centre, radius = np.array([0.1, 0.2, 0.3]), 0.18
    lever = 1.7 - Q2  # clockwise about the normal
    points = centre + radius * (np.cos(lever)[:, None] * e1 + np.sin(lever)[:, None] * e2)
    fit = known_angle_fit(Q2, points)
    assert fit.radius == pytest.approx(radius)
    np.testing.assert_allclose(fit.centre, centre, atol=1e-14)
    np.testing.assert_allclose(fit.axis, -normal, atol=1e-12)
    assert fit.sense == -1
    assert fit.R.shape == (3, 2)


def test_concentric_fit_recovers_exact_planar_arcs():
    p0 = np.array([-0.68, -0.12])
    sets = {
        "A": p0 + 0.19 * np.column_stack([np.cos(b := np.linspace(2.6, 3.1, 6)), np.sin(b)]),
        "B": p0 + 0.20 * np.column_stack([np.cos(b := np.linspace(-2.3, -2.8, 6)), np.sin(b)]),
    }
    fit = concentric_fit(sets)
    np.testing.assert_allclose(fit.centre, p0, atol=1e-12)
    assert fit.radii == pytest.approx({"A": 0.19, "B": 0.20})
    assert fit.axis is None
    assert fit.rms("A") < 1e-12


def test_concentric_fit_in_3d_resolves_the_axis_ambiguity():
    e1, e2, normal = tilted_frame(0.3)
    p0 = np.array([-0.7, -0.1, 0.05])
    sets = {}
    for name, radius, height, span in (("A", 0.19, 0.02, (2.6, 3.1)), ("B", 0.2, -0.03, (-2.3, -2.8))):
        b = np.linspace(*span, 6)
        sets[name] = p0 + height * normal + radius * (np.cos(b)[:, None] * e1 + np.sin(b)[:, None] * e2)
    fit = concentric_fit(sets)
    assert abs(abs(fit.axis @ normal) - 1) < 1e-10
    # Eqs 26-29 put the centre at the mean height of the points along the axis.
    mean_height = np.mean(np.vstack(list(sets.values())) @ normal)
    np.testing.assert_allclose(fit.centre, p0 + (mean_height - p0 @ normal) * normal, atol=1e-10)
    # Eq 21's radii are distances from that centre.
    expected = {n: float(np.sqrt(np.mean(np.sum((p - fit.centre) ** 2, axis=1)))) for n, p in sets.items()}
    assert fit.radii == pytest.approx(expected)


def test_3d_data_gives_the_same_geometry_as_its_planar_projection(table1):
    z = 0.25 + 1e-5 * (np.arange(len(table1.marker)) % 3)
    xyz = np.column_stack([table1.xyz, z])
    points = MarkerPoints.from_arrays(table1.marker, table1.q2, xyz)
    fit3 = CompensatorGeometryModel().fit(points)
    fit2 = CompensatorGeometryModel().fit(table1)
    assert fit3.geometry.L == pytest.approx(fit2.geometry.L, rel=1e-6)
    assert fit3.axis_tilt is not None
    assert "axis_tilt" in fit3.summary().index


def test_a_mirrored_frame_is_detected_and_undone(table1, table1_fit):
    mirrored = MarkerPoints.from_arrays(table1.marker, table1.q2, table1.xyz * np.array([1.0, -1.0]))
    with pytest.warns(UserWarning, match="counter-clockwise"):
        fit = CompensatorGeometryModel().fit(mirrored)
    assert fit.mirrored
    assert fit.geometry.a_y == pytest.approx(table1_fit.geometry.a_y, rel=1e-9)
    assert fit.geometry.phi == pytest.approx(table1_fit.geometry.phi, rel=1e-9)


def test_layout_reproduces_table1_and_simulates(table1, table1_fit):
    layout = MarkerLayout.from_fit(table1_fit, table1)
    q2, p1 = table1.of("P1")
    assert np.sqrt(np.mean(np.sum((layout.positions(q2)["P1"] - p1) ** 2, axis=1))) < 0.1 * MM
    simulated = simulate_markers(layout, Q2, np.random.default_rng(0), sigma=0.0)
    exact = CompensatorGeometryModel().fit(simulated)
    assert exact.geometry.L == pytest.approx(layout.L, rel=1e-12)
    np.testing.assert_allclose(exact.p0, layout.p0, atol=1e-9)


HEADER = "q2_deg,marker,x_mm,y_mm"
GOOD_ROWS = [
    "-0.01,P1,-31.84,183.86",
    "-0.01,P01,-872.10,-125.38",
    "-30,P1,-118.44,143.42",
    "-30,P01,-872.30,-126.07",
    "-60,P1,-173.30,65.12",
    "-60,P01,-872.50,-109.90",
]


def write(tmp_path, rows, header=HEADER):
    path = tmp_path / "points.csv"
    path.write_text("# test points\n" + "\n".join([header, *rows]) + "\n")
    return path


def test_a_minimal_good_file_reads(tmp_path):
    points = read_arc_points(write(tmp_path, GOOD_ROWS))
    assert points.markers == ["P1", "P01"]
    assert list(points.line) == [3, 4, 5, 6, 7, 8]


def test_optional_z_column_is_read(tmp_path):
    rows = [row + f",{i}" for i, row in enumerate(GOOD_ROWS)]
    points = read_arc_points(write(tmp_path, rows, HEADER + ",z_mm"))
    assert points.dim == 3
    assert points.xyz[2, 2] == pytest.approx(2 * MM)


@pytest.mark.parametrize(
    ("rows", "header", "message"),
    [
        (GOOD_ROWS, "q2_deg,marker,x_mm", r"points\.csv:2: missing column 'y_mm'"),
        ([GOOD_ROWS[0].replace("183.86", "nan"), *GOOD_ROWS[1:]], HEADER, r"points\.csv:3, column 'y_mm'"),
        ([GOOD_ROWS[0].replace("183.86", "abc"), *GOOD_ROWS[1:]], HEADER, r"points\.csv:3, column 'y_mm'.*'abc'"),
        (GOOD_ROWS[:4], HEADER, r"marker P1 has 2 angles; an arc needs at least 3"),
        ([*GOOD_ROWS[:5], "-60,P02,-872.50,-109.90"], HEADER, r"marker P01 has 2 points"),
        ([*GOOD_ROWS, "-60,P02,-872.50,-109.90"], HEADER, r"points\.csv:9, column 'marker': marker P02 has 1 point;"),
        (
            [r.replace("-872.30,-126.07", "-872.10,-125.38").replace("-872.50,-109.90", "-872.10,-125.38") for r in GOOD_ROWS],
            HEADER,
            r"all points of marker P01 are identical",
        ),
        ([*GOOD_ROWS[:5], "-60,P01,-872.50,-126.76"], HEADER, r"points of marker P01 are collinear"),
        ([*GOOD_ROWS, "-90,Q7,1,2"], HEADER, r"points\.csv:9, column 'marker': unknown marker 'Q7'"),
        ([*GOOD_ROWS, "-30,P1,1,2"], HEADER, r"points\.csv:9, column 'q2_deg': marker P1 has two rows at q2 = -30 deg"),
        ([r for r in GOOD_ROWS if "P01" not in r], HEADER, r"no P0<k> rows"),
        ([r for r in GOOD_ROWS if "P1," not in r], HEADER, r"no P1 rows"),
    ],
)
def test_bad_input_gives_one_line_errors(tmp_path, rows, header, message):
    with pytest.raises(InputError, match=message) as error:
        read_arc_points(write(tmp_path, rows, header))
    assert "\n" not in str(error.value)
    assert "points.csv" in str(error.value)


@pytest.mark.parametrize(
    ("factor", "message"),
    [(1e-3, "are x_mm, y_mm in metres instead of mm?"), (1e3, "beyond any tracker's range (100 m): are x_mm, y_mm in another unit")],
)
def test_table1_in_another_unit_is_rejected(tmp_path, data_dir, factor, message):
    # Table I in metres gave L = 0.185 mm beside the paper's 184.72 mm without a word.
    lines = (data_dir / "table1_geometry.csv").read_text().splitlines()
    scaled = [
        line if line.startswith(("#", "q2")) else ",".join([*line.split(",")[:2], *(f"{float(v) * factor:.8g}" for v in line.split(",")[2:])])
        for line in lines
    ]
    path = tmp_path / "points.csv"
    path.write_text("\n".join(scaled) + "\n")
    with pytest.raises(InputError) as raised:
        read_arc_points(path)
    assert message in str(raised.value) and "column 'x_mm'" in str(raised.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_arc_points(tmp_path / "absent.csv")


def test_concentric_centre_along_the_axis_minimises_the_sum_of_squared_radii_with_unequal_arcs():
    # Eqs 26-27: sum_j R_j^2 is least halfway between the arcs' planes, whatever their point counts.
    a = np.linspace(0.0, 1.2, 8)
    b = np.linspace(0.3, 1.1, 3)
    arcs = {
        "P01": np.column_stack([np.cos(a), np.sin(a), np.full(a.size, 0.1)]),
        "P02": np.column_stack([2 * np.cos(b), 2 * np.sin(b), np.full(b.size, -0.1)]),
    }
    fit = concentric_fit(arcs)
    np.testing.assert_allclose(fit.centre, [0.0, 0.0, 0.0], atol=1e-9)


def test_q2_written_in_radians_is_refused(tmp_path, data_dir):
    import pandas as pd

    points = pd.read_csv(data_dir / "table1_geometry.csv", comment="#")
    path = tmp_path / "points.csv"
    points.assign(q2_deg=np.deg2rad(points["q2_deg"])).to_csv(path, index=False)
    with pytest.raises(InputError, match=r"column 'q2_deg': marker P1 moves as if on a circle of radius 10.5 m .* are q2 in deg, not rad\?"):
        read_arc_points(path)
