import json

import numpy as np
import pandas as pd
import pytest

from bayescal.critique.geometry import GEOMETRY_CATALOGUE, GeometryCritique, _fit, _Spec
from bayescal.errors import InputError
from bayescal.geometry.arcs import CompensatorGeometryModel, MarkerLayout, read_arc_points
from bayescal.twin.arcs import simulate_markers
from bayescal.units import DEG, MM


@pytest.fixture(scope="module")
def table_i(data_dir):
    return read_arc_points(data_dir / "table1_geometry.csv")


@pytest.fixture(scope="module")
def layout(table_i):
    """Table I's closed-form geometry, the markers rigid on the cylinder."""
    return MarkerLayout.from_fit(CompensatorGeometryModel().fit(table_i), table_i)


@pytest.fixture(scope="module")
def angles(table_i):
    return np.unique(table_i.q2)


# Another compensator and plan than Table I's: shorter lever, other pivot and marker places, 8 angles.
OTHER_LAYOUT = MarkerLayout(
    p2=np.array([0.05, -0.02]), L=0.160, phi=70 * DEG, sense=-1, p0=np.array([-0.62, -0.15]),
    cylinder={"P01": (0.150, 175 * DEG), "P02": (0.170, 215 * DEG)},
)
OTHER_ANGLES = np.radians(np.linspace(-150.0, 10.0, 8))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_effect_is_adequate(layout, angles, seed):
    results = GeometryCritique().run(simulate_markers(layout, angles, np.random.default_rng(seed)))
    assert results.verdict == "adequate" and results.causes == []


@pytest.mark.parametrize("effect", list(GEOMETRY_CATALOGUE))
def test_a_planted_effect_is_named_first(layout, angles, effect):
    results = GeometryCritique().run(simulate_markers(layout, angles, np.random.default_rng(10), effect))
    assert results.causes[:1] == [effect]


def test_an_effect_outside_the_catalogue_is_unexplained_and_follows_q2(layout, angles):
    """A lever bending under the spring force: its misfit reaches the cylinder markers through the
    lever's direction, so a cylinder extension may be named before it (docs/critique.md)."""
    results = GeometryCritique().run(simulate_markers(layout, angles, np.random.default_rng(0), "lever_bending"))
    assert results.verdict == "misfit" and results.causes[-1] == "unexplained"
    assert results.unexplained_covariate == "q2_squared"


def test_another_compensator_and_plan(layout):
    assert GeometryCritique().run(simulate_markers(OTHER_LAYOUT, OTHER_ANGLES, np.random.default_rng(3))).verdict == "adequate"
    found = GeometryCritique().run(simulate_markers(OTHER_LAYOUT, OTHER_ANGLES, np.random.default_rng(4), "pivot_motion"))
    assert found.causes[:1] == ["pivot_motion"]


def test_the_base_fit_is_the_closed_form_geometry_on_exact_points(layout, angles):
    exact = simulate_markers(layout, angles, np.random.default_rng(0), sigma=0.0)
    fitted = _fit(exact, _Spec(), angles)
    theta = dict(zip(fitted.names, fitted.theta))
    assert np.allclose([theta["p2_x"], theta["p2_y"], theta["p0_x"], theta["p0_y"]], [*layout.p2, *layout.p0], atol=1e-9)
    assert theta["L"] == pytest.approx(layout.L, abs=1e-9)
    assert theta["delta[P02]"] == pytest.approx(layout.cylinder["P02"][1], abs=1e-9)


def test_a_planted_tilt_is_estimated(layout):
    angles = np.radians(np.linspace(-150.0, 10.0, 12))
    points = simulate_markers(layout, angles, np.random.default_rng(0), "tilt", 5 * DEG, sigma=0.005 * MM)
    fitted = _fit(points, _Spec(("tilt",)), angles)
    estimate = fitted.extension_parameters()
    assert estimate["tilt_deg"] == pytest.approx(5.0, abs=3 * estimate["tilt_sd_deg"])
    assert estimate["tilt_axis_deg"] == pytest.approx(60.0, abs=3.0)
    # the geometry in the compensator's plane, not its projection
    geometry = fitted.geometry()
    assert geometry["L_mm"] == pytest.approx(layout.L / MM, abs=3 * geometry["L_sd_mm"])
    assert geometry["a_x_mm"] == pytest.approx((layout.p2[0] - layout.p0[0]) / MM, abs=3 * geometry["a_x_sd_mm"])
    assert abs(geometry["L_mm"] - layout.L / MM) < 0.01


def test_held_out_predictive_covers_at_its_nominal_rate(layout, angles):
    """The Student-t predictive's central 90 % interval of each held-out coordinate, over null campaigns."""
    from scipy import stats

    inside = []
    for seed in range(6):
        points = simulate_markers(layout, angles, np.random.default_rng(100 + seed))
        for angle in angles:
            out = points.q2 == angle
            fitted = _fit(type(points)(points.marker[~out], points.q2[~out], points.xyz[~out], points.line[~out]), _Spec(), angles)
            mean = fitted.predict(points.q2[out], points.marker[out]).ravel()
            J = fitted.jacobian(points.q2[out], points.marker[out])
            spread = np.sqrt(np.diag(J @ fitted.cov @ J.T))
            level = np.repeat([fitted.sigma["lever" if m == "P1" else "cylinder"] for m in points.marker[out]], 2)
            dof = np.repeat([fitted.dof["lever" if m == "P1" else "cylinder"] for m in points.marker[out]], 2)
            z = (points.xyz[out].ravel() - mean) / np.sqrt(level**2 + spread**2)
            inside.append(np.abs(z) < stats.t.ppf(0.95, dof))
    coverage = np.mean(np.concatenate(inside))
    assert 0.84 < coverage < 0.96, coverage


def test_results_on_table_i(table_i, tmp_path):
    results = GeometryCritique().run(table_i)
    payload = results.to_json()
    assert set(payload) >= {"verdict", "causes", "evidence", "gain"}
    assert set(payload["evidence"]) == set(GEOMETRY_CATALOGUE)
    assert all({"delta_elpd", "se", "step", "named"} <= set(entry) for entry in payload["evidence"].values())
    assert payload["verdict"] == ("misfit" if payload["causes"] else "adequate")
    assert payload["n_angles"] == 6 and payload["n_points"] == 18
    for name in payload["causes"]:
        entry = payload["evidence"][name]
        assert entry["named"] and entry["delta_elpd"] > max(2 * entry["se"], 4.0)
    summary = results.summary()
    assert isinstance(summary, pd.DataFrame) and summary["named"].sum() == len([c for c in results.causes if c in GEOMETRY_CATALOGUE])
    results.save(tmp_path / "geometry_critique.json")
    assert json.loads((tmp_path / "geometry_critique.json").read_text()) == payload


def test_too_few_angles_is_an_input_error(layout):
    points = simulate_markers(layout, np.radians([-120.0, -80.0, -40.0, 0.0]), np.random.default_rng(0))
    with pytest.raises(InputError, match="at least 5"):
        GeometryCritique().run(points)


def test_a_mirrored_tracker_frame_gives_the_same_critique(table_i):
    from bayescal.geometry.arcs import MarkerPoints

    mirrored = MarkerPoints.from_arrays(table_i.marker, table_i.q2, table_i.xyz * np.array([1.0, -1.0]))
    a, b = GeometryCritique().run(table_i), GeometryCritique().run(mirrored)
    assert a.causes == b.causes and a.gain.delta_elpd == pytest.approx(b.gain.delta_elpd, abs=1e-6)
    assert a.to_json()["geometry"] == b.to_json()["geometry"]


def test_z_is_ignored_with_a_warning(table_i):
    from bayescal.geometry.arcs import MarkerPoints

    xyz = np.column_stack([table_i.xyz, np.full(table_i.q2.size, 0.3)])
    with pytest.warns(UserWarning, match="ignores z_mm"):
        spatial = GeometryCritique().run(MarkerPoints.from_arrays(table_i.marker, table_i.q2, xyz))
    assert spatial.causes == GeometryCritique().run(table_i).causes


def test_unknown_candidate_is_refused():
    with pytest.raises(ValueError, match="unknown candidate"):
        GeometryCritique(catalogue=("tilt", "wobble"))


@pytest.mark.slow
def test_no_effect_is_adequate_in_at_least_95_percent_of_40_seeds(layout, angles):
    campaigns = (simulate_markers(layout, angles, np.random.default_rng(1000 + seed)) for seed in range(40))
    verdicts = [GeometryCritique().run(points).verdict for points in campaigns]
    assert verdicts.count("adequate") >= 38


def test_the_results_have_the_four_verbs(tmp_path, table_i):
    results = GeometryCritique().run(table_i)
    assert len(results.summary()) > 0
    diagnostics = results.diagnostics()
    assert diagnostics["n_angles"] == results.n_angles == 6
    assert diagnostics["held_out_rms_mm"]["final"] <= diagnostics["held_out_rms_mm"]["two_step"]
    results.save(tmp_path / "critique.json")
    assert json.loads((tmp_path / "critique.json").read_text())["verdict"] == results.to_json()["verdict"]
