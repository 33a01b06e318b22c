"""The sweep simulator: one joint moves at a time; readings are the flange reflectors seen from the placed tracker."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayescal.cell.tracker import TrackerNoise
from bayescal.twin.sweeps import random_placement, simulate_sweeps
from bayescal.units import DEG, MM


def test_noise_free_readings_are_the_reflectors_in_the_tracker_frame(cell):
    quiet = replace(cell, tracker=TrackerNoise(U0=0.0, U1=0.0, factor=0.0))
    rng = np.random.default_rng(0)
    placement = random_placement(rng)
    table = simulate_sweeps(quiet, placement, rng, home_deg=[10, -80, 70, 0, 30, 0], joints=(0, 2), angles=5)
    assert len(table) == 2 * 5 * 3
    for joint in (1, 3):
        sweep = table[table.joint == joint]
        still = [c for c in sweep.columns if c.endswith("_deg") and c != f"q{joint}_deg"]
        assert (sweep[still].nunique() == 1).all() and sweep[f"q{joint}_deg"].nunique() == 5
    row = table.iloc[7]
    q = row[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(float) * DEG
    base = cell.robot.point_position(q, np.array([-80.0, 130.0, 50.0]) * MM)
    tracker = row[["x_mm", "y_mm", "z_mm"]].to_numpy(float) * MM
    assert np.allclose(placement.rotation @ tracker + placement.position, base, atol=1e-9)
