"""Registrations from sweeps simulated by the robot's forward kinematics (bayescal.twin.sweeps), tracker placed at random."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import norm

from bayescal.errors import InputError
from bayescal.registration import read_frame, read_sweeps, register
from bayescal.registration.register import RegistrationFindings
from bayescal.registration.frames import paper_frame, urdf_axes
from bayescal.registration.robust import interval_factor
from bayescal.twin.sweeps import random_placement, simulate_sweeps
from bayescal.units import DEG

HOME = [0.0, -90.0, 90.0, 0.0, 45.0, 0.0]


def _registration(cell, rng, tmp_path, name="sweeps.csv", **options):
    placement = random_placement(rng)
    table = simulate_sweeps(cell, placement, rng, home_deg=options.pop("home_deg", HOME), **options)
    path = tmp_path / name
    table.to_csv(path, index=False)
    return placement, register(read_sweeps(path), cell, rng=rng, draws=200)


def _truth(cell, placement):
    """Axes 1, 2 and the paper and base frames in the tracker frame, from the URDF and the placement."""
    axes = urdf_axes(cell.robot, np.array(HOME) * DEG)
    R = placement.rotation.T
    lines = [(R @ u, placement.to_tracker(p[None])[0]) for u, p in axes]
    Rp, tp = paper_frame(*axes[0], *axes[1])
    return lines, {"paper": (R @ Rp, placement.to_tracker(tp[None])[0]), "base": (R, placement.to_tracker(np.zeros((1, 3)))[0])}


def _standardised_errors(cell, placement, registration) -> tuple[np.ndarray, np.ndarray]:
    """Each estimated component's error over its sd, and the sd's degrees of freedom: axes 1-2 across the axis,
    frames' rotation and translation."""
    lines, frames = _truth(cell, placement)
    z, dof = [], []
    for j, (a, c) in enumerate(lines):
        fit = registration.axes[j]
        seed = np.eye(3)[int(np.argmin(np.abs(a)))]
        b1 = np.cross(a, seed) / np.linalg.norm(np.cross(a, seed))
        for b in (b1, np.cross(a, b1)):
            # The nearest point moves along the axis too when the axis tilts: compare across the axis only.
            for error, contrast in ((fit.direction - a, np.r_[b, 0, 0, 0]), (fit.point - c, np.r_[0, 0, 0, b])):
                z.append(b @ error / np.sqrt(contrast @ fit.cov @ contrast))
                dof.append(fit.interval_dof(contrast))
    for name, (R, t) in frames.items():
        frame = registration.frames[name]
        z += list(Rotation.from_matrix(frame.rotation @ R.T).as_rotvec() / np.sqrt(np.diag(frame.rotation_cov)))
        z += list((frame.translation - t) / np.sqrt(np.diag(frame.translation_cov)))
        dof += list(frame.rotation_dof) + list(frame.translation_dof)
    return np.array(z), np.array(dof)


def test_axes_and_frames_recovered_within_their_uncertainty(cell, tmp_path):
    rng = np.random.default_rng(11)
    for k in range(3):
        placement, registration = _registration(cell, rng, tmp_path, f"s{k}.csv")
        z, dof = _standardised_errors(cell, placement, registration)
        assert np.all(np.abs(z) < interval_factor(4.5, dof)), (z, dof)
        lines, frames = _truth(cell, placement)
        assert np.linalg.norm(registration.frames["base"].translation - frames["base"][1]) < 1e-3  # m
        assert registration.axes[0].residual_rms < 0.2e-3


def test_results_json_names_units_and_what_comes_from_the_urdf(cell, tmp_path):
    _, registration = _registration(cell, np.random.default_rng(3), tmp_path)
    payload = registration.to_json()
    assert set(payload["axes"]) == {"1", "2"}
    assert {"direction", "direction_sd_mrad", "point_mm", "point_sd_mm", "rms_mm"} <= set(payload["axes"]["1"])
    assert {"rotation", "translation_mm", "from_nominal"} <= set(payload["frames"]["base"])
    assert "height" in payload["frames"]["base"]["from_nominal"]
    assert len(registration.diagnostics()) == 6 and len(registration.summary()) == 2


def test_sweeps_from_different_home_poses_are_refused(cell, tmp_path):
    rng = np.random.default_rng(5)
    placement = random_placement(rng)
    first = simulate_sweeps(cell, placement, rng, home_deg=HOME, joints=(0,))
    other = list(HOME)
    other[2] += 10.0
    second = simulate_sweeps(cell, placement, rng, home_deg=other, joints=(1,))
    path = tmp_path / "mixed.csv"
    pd.concat([first, second]).to_csv(path, index=False)
    with pytest.raises(InputError, match="one home pose") as error:
        register(read_sweeps(path), cell)
    assert error.value.column == "q3_deg"


@pytest.mark.slow
def test_registration_coverage_over_200_simulated_registrations(cell, tmp_path):
    """±1/2/3 sd coverage of every component (axes 1-2 across the axis, both frames), tracker placed and turned at random."""
    rng = np.random.default_rng(2026)
    z, dof = np.array([_standardised_errors(cell, *_registration(cell, rng, tmp_path, f"s{k}.csv")) for k in range(200)]).transpose(1, 0, 2)
    for k in (1, 2, 3):
        nominal = 2 * norm.cdf(k) - 1
        # Components of one registration are correlated: binomial sd over the 200 registrations, 4 sd allowed.
        tolerance = 4 * np.sqrt(nominal * (1 - nominal) / 200)
        covered = np.mean(np.abs(z) < interval_factor(k, dof), axis=0)
        assert abs(np.mean(covered) - nominal) < tolerance / 2, (k, np.mean(covered))
        assert np.all(np.abs(covered - nominal) < tolerance), (k, covered)


def test_saved_base_frame_moves_tracker_points_into_the_base_frame(cell, tmp_path):
    rng = np.random.default_rng(21)
    placement, registration = _registration(cell, rng, tmp_path)
    registration.save(tmp_path / "registration.json")
    frame = read_frame(tmp_path / "registration.json", "base")
    points = rng.uniform(-1.5, 1.5, size=(20, 3)) + [1.0, 0.0, 1.0]  # m, in the base frame
    moved = frame.from_tracker(placement.to_tracker(points))
    # A point r from the frame's origin moves by about |r|·rotation error plus the translation error.
    sd = np.sqrt(np.trace(frame.rotation_cov)) * np.linalg.norm(points, axis=1) + np.sqrt(np.trace(frame.translation_cov))
    assert np.all(np.linalg.norm(moved - points, axis=1) < 5 * sd)


def test_a_registration_without_frames_is_refused(cell, tmp_path):
    rng = np.random.default_rng(4)
    _, registration = _registration(cell, rng, tmp_path, joints=(1,))
    registration.save(tmp_path / "one_joint.json")
    with pytest.raises(InputError, match=r"no base frame: sweep joint 1 \(it holds the axis of joint 2 only"):
        read_frame(tmp_path / "one_joint.json", "base")


def test_the_registration_s_json_round_trips_through_its_findings(cell, tmp_path):
    _, registration = _registration(cell, np.random.default_rng(3), tmp_path)
    registration.save(tmp_path / "reg.json")
    data = json.loads((tmp_path / "reg.json").read_text())
    findings = RegistrationFindings.load(tmp_path / "reg.json")
    assert findings.to_json() == data and list(findings.to_json()) == list(data)
    assert set(findings.frames) == {"paper", "base"} and findings.axes["1"]["point_mm"] == data["axes"]["1"]["point_mm"]
    assert findings.critique is None and findings.extra["home_deg"] == data["home_deg"]


def test_a_file_that_is_not_a_registration_is_one_line_naming_it(tmp_path):
    path = tmp_path / "reg.json"
    path.write_text(json.dumps({"axes": {}, "frames": [], "robot": "kr270"}))
    with pytest.raises(InputError, match="reg.json.*expected the key 'frames' of the output of bayescal axes -o, found a list"):
        RegistrationFindings.load(path)
