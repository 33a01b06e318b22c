from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from bayescal.geometry.arcs import MarkerLayout
from bayescal_studies.studies.geometry_critique import PLANTED, TILT_AXIS, geometry_detection, simulate_markers
from bayescal.units import DEG

LAYOUT = MarkerLayout(
    p2=np.array([0.0, 0.0]), L=0.185, phi=100 * DEG, sense=-1, p0=np.array([-0.686, -0.119]),
    cylinder={"P01": (0.187, 158 * DEG), "P02": (0.188, 202 * DEG)},
)
ANGLES = np.radians([-145.0, -120.0, -90.0, -60.0, -30.0, 0.0])


def _exact(effect=None, magnitude=None):
    points = simulate_markers(LAYOUT, ANGLES, np.random.default_rng(0), effect, magnitude, sigma=0.0)
    return {name: points.of(name)[1] for name in points.markers}


def test_without_effect_the_points_are_the_layout():
    exact = _exact()
    for name, xy in LAYOUT.positions(ANGLES).items():
        assert np.allclose(exact[name], xy)


def test_tilt_shortens_across_its_axis_by_cos_t_and_keeps_lengths_along_it():
    plain, tilted = _exact(), _exact("tilt", 10 * DEG)
    along = np.array([np.cos(TILT_AXIS), np.sin(TILT_AXIS)])
    across = np.array([-along[1], along[0]])
    d_plain = plain["P1"] - plain["P01"]
    d_tilted = tilted["P1"] - tilted["P01"]
    assert np.allclose(d_tilted @ along, d_plain @ along)
    assert np.allclose(d_tilted @ across, np.cos(10 * DEG) * (d_plain @ across))


def test_pivot_motion_and_slip_leave_the_lever_and_move_the_cylinder_markers():
    plain = _exact()
    for effect in ("pivot_motion", "cylinder_slip"):
        moved = _exact(effect)
        assert np.allclose(moved["P1"], plain["P1"])
        assert np.all(np.linalg.norm(moved["P01"] - plain["P01"], axis=1) > 1e-5)


def test_lever_bending_moves_the_lever_marker_along_its_arc_only():
    plain, bent = _exact(), _exact("lever_bending")
    assert np.allclose(bent["P01"], plain["P01"]) and np.allclose(bent["P02"], plain["P02"])
    shift = np.linalg.norm(bent["P1"] - plain["P1"], axis=1)
    assert np.allclose(np.linalg.norm(bent["P1"] - LAYOUT.p2, axis=1), np.hypot(LAYOUT.L, shift))


def test_joint_scale_turns_every_marker_with_the_joint():
    assert np.allclose(_exact("joint_scale", 0.01)["P02"], LAYOUT.positions(ANGLES * 1.01)["P02"])


def test_slip_keeps_the_markers_on_their_circles():
    moved = _exact("cylinder_slip", 0.05)
    for name, (radius, _) in LAYOUT.cylinder.items():
        assert np.allclose(np.linalg.norm(moved[name] - LAYOUT.p0, axis=1), radius)


def test_closed_loop_makes_the_lever_noisier_only():
    points = simulate_markers(LAYOUT, ANGLES, np.random.default_rng(1), "closed_loop", 50.0, sigma=1e-5)
    exact = _exact()
    assert np.std(points.of("P1")[1] - exact["P1"]) > 10 * np.std(points.of("P01")[1] - exact["P01"])


def test_unknown_effect_is_refused():
    with pytest.raises(ValueError, match="unknown effect"):
        simulate_markers(LAYOUT, ANGLES, np.random.default_rng(0), "wobble")


def test_detection_table():
    with ThreadPoolExecutor(1) as executor:
        table = geometry_detection(LAYOUT, ANGLES, {"cylinder_slip": [PLANTED["cylinder_slip"][0]]}, n_seeds=2, n_null=2, executor=executor)
    assert list(table["effect"]) == ["none", "cylinder_slip"]
    assert list(table["campaigns"]) == [2, 2]
    assert table.loc[1, "first_cause"] == 1.0 and table.loc[0, "misfit"] == 0.0
