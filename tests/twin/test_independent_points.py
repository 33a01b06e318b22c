"""Tests of bayescal.twin.independent.points: the independent simulator of absolute marker positions."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from bayescal.errors import InputError
from bayescal.twin.independent import points
from bayescal.twin.independent.points import (
    configurations,
    draw_world,
    marker_positions,
    positions_frame,
    write_positions,
)


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    t = np.eye(4)
    t[i, i], t[i, j], t[j, i], t[j, j] = c, -s, s, c
    return t


def _shift(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = x, y, z
    return t


def _nominal_markers(q: np.ndarray) -> np.ndarray:
    """(2, 3) markers of the nominal table composed column by column, one configuration ``q`` (19,) rad."""
    deg = np.pi / 180

    def column(d, theta, r, alpha, angle):
        return _rot(0, alpha * deg) @ _shift(r, 0, 0) @ _rot(2, theta * deg + angle) @ _shift(0, 0, d)

    torso = [(0.1055, 0, 0, 0), (0, -90, 0, -90), (0, 0, 0.3, 0), (0, 0, 0.3, 0)]
    right = [(0, 0, 0, 0), (0, 0, 0, 90), (0.4, -90, 0, -90), (0, 0, 0, 90), (0.39, -180, 0, -90)]
    right += [(0, 90, 0, 90), (0, -90, 0, 90)]
    left = [(0, 0, 0, 180), (0, 0, 0, 90), (-0.4, -90, 0, -90), (0, 0, 0, 90), (-0.39, 0, 0, -90)]
    left += [(0, 90, 0, -90), (0, -90, 0, -90)]
    shoulder = _shift(-2.5, 2.0, 0.1) @ _rot(2, 90 * deg)
    for row, angle in zip(torso, [q[0], q[1], q[2], -q[1] - q[2]]):
        shoulder = shoulder @ column(*row, angle)
    out = []
    for table, angles, mount, marker in [
        (right, q[3:10], _shift(0, 0, 0.25) @ _rot(2, 30 * deg), [-0.1, -0.03, 0.1]),
        (left, q[10:17], _shift(0, 0, -0.25) @ _rot(2, -30 * deg), [-0.1, 0.03, 0.05]),
    ]:
        hand = shoulder @ mount
        for row, angle in zip(table, angles):
            hand = hand @ column(*row, angle)
        out.append((hand @ [*marker, 1.0])[:3])
    return np.array(out)


@pytest.fixture(scope="module")
def joints() -> np.ndarray:
    return configurations(np.random.default_rng(11), 12)


def test_configurations_in_range_and_above_the_table(joints):
    assert joints.shape == (12, 19)
    assert np.all(joints >= points.JOINT_RANGES[:, 0]) and np.all(joints <= points.JOINT_RANGES[:, 1])
    assert np.all(joints[:, 17:] == 0)
    assert np.all(marker_positions(points._NOMINAL, joints)[..., 2] >= points.MIN_MARKER_HEIGHT)


def test_all_effects_off_is_the_nominal_table(joints):
    world = draw_world(np.random.default_rng(3), noise_sd=0.0, elastic=False, kinematic_errors=False)
    got = marker_positions(world, joints[:4], noise_rng=np.random.default_rng(4))
    expected = np.array([_nominal_markers(q) for q in joints[:4]])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)


def test_effects_move_the_markers(joints):
    on = marker_positions(draw_world(np.random.default_rng(3)), joints)
    kinematics = marker_positions(draw_world(np.random.default_rng(3), elastic=False), joints)
    expected = np.array([_nominal_markers(q) for q in joints])
    assert np.linalg.norm(on - kinematics, axis=-1).mean() > 1e-3  # the self-weight
    assert np.linalg.norm(kinematics - expected, axis=-1).mean() > 5e-3  # base, mounts, markers, DH errors


def test_elastic_deflection_converged_linear_and_realistic(joints):
    world = draw_world(np.random.default_rng(5))
    columns = points._columns(world, joints)
    phi = points._solve(world, columns)
    once_more = points._forward(world, columns, points._step(world, columns, phi))[2]
    assert np.max(np.abs(once_more - points._forward(world, columns, phi)[2])) < 1e-9

    rigid = marker_positions(replace(world, compliances=0 * world.compliances), joints)
    deflection = np.linalg.norm(marker_positions(world, joints) - rigid, axis=-1)
    doubled_world = replace(world, compliances=2 * world.compliances)
    doubled = np.linalg.norm(marker_positions(doubled_world, joints) - rigid, axis=-1)
    assert doubled.mean() / deflection.mean() == pytest.approx(2.0, abs=0.05)
    assert 1e-3 < deflection.mean() < 20e-3

    no_transversal = draw_world(np.random.default_rng(5), transversal=False)
    assert np.all(no_transversal.compliances[:, :2] == 0)
    np.testing.assert_array_equal(no_transversal.compliances[:, 2], world.compliances[:, 2])


def test_reproducible_from_a_seed_with_noise_of_the_given_size(joints):
    def run(seed):
        rng = np.random.default_rng(seed)
        world = draw_world(rng, noise_sd=1e-3)
        return world, configurations(rng, 200), rng

    (world, q, rng), (again, q_again, rng_again) = run(7), run(7)
    assert json.dumps(world.to_json()) == json.dumps(again.to_json())
    np.testing.assert_array_equal(q, q_again)
    noisy = marker_positions(world, q, noise_rng=rng)
    np.testing.assert_array_equal(noisy, marker_positions(again, q_again, noise_rng=rng_again))
    assert np.std(noisy - marker_positions(world, q)) == pytest.approx(1e-3, rel=0.1)
    assert draw_world(np.random.default_rng(8)).to_json() != world.to_json()


def test_to_json_units_at_the_edge():
    world = draw_world(np.random.default_rng(9), kinematic_errors=False)
    out = world.to_json()
    assert out["base"]["translation_mm"] == pytest.approx([-2500.0, 2000.0, 100.0])
    assert out["base"]["rotation_vector_deg"] == pytest.approx([0.0, 0.0, 90.0])
    assert out["markers_mm"]["left"] == pytest.approx([-100.0, 30.0, 50.0])
    assert [j["name"] for j in out["joints"]][:5] == ["torso_1", "torso_2", "torso_3", "torso_4", "right_1"]
    arm = [j["compliance_z_urad_per_nm"] for j in out["joints"][4:]]
    assert 20 <= min(arm) and max(arm) <= 300


def test_write_positions_reads_back(tmp_path, joints):
    world = draw_world(np.random.default_rng(10))
    positions = marker_positions(world, joints, noise_rng=np.random.default_rng(1))
    path = tmp_path / "positions.csv"
    write_positions(path, joints, positions, header="independent points generator\nseed 10")
    lines = path.read_text().splitlines()
    assert lines[:2] == ["# independent points generator", "# seed 10"]
    assert "e-" not in path.read_text() and "e+" not in path.read_text()
    table = pd.read_csv(path, comment="#")
    assert list(table.columns) == [f"q{i}_deg" for i in range(1, 20)] + ["marker", "x_mm", "y_mm", "z_mm"]
    assert list(table["marker"][:4]) == ["right", "left", "right", "left"]
    np.testing.assert_allclose(table[["x_mm", "y_mm", "z_mm"]].to_numpy(), positions.reshape(-1, 3) * 1e3, atol=1e-9)
    np.testing.assert_allclose(table.iloc[::2, :19].to_numpy(), np.degrees(joints), atol=1e-9)
    pd.testing.assert_frame_equal(table, positions_frame(joints, positions), atol=1e-9)


def test_bad_shapes_refused(joints):
    world = draw_world(np.random.default_rng(0))
    with pytest.raises(InputError, match=r"\(n, 19\)"):
        marker_positions(world, joints[:, :18])
    with pytest.raises(InputError, match=r"\(12, 2, 3\)"):
        positions_frame(joints, np.zeros((12, 3)))
