"""Shared fixtures of the kinematic calibration's tests: Justin's cell, simulated positions files, the real data set."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from bayescal.kinematics import KinematicCalibration, load_points_cell

ROOT = Path(__file__).resolve().parents[2]
JUSTIN_CELL = ROOT / "data" / "robots" / "justin.toml"
JUSTIN_DATA = ROOT.parent / "shared" / "data" / "dlr-justin" / "measurements.csv"
"""DLR's published measurements, read in place where present (never copied into the repository)."""

sys.path.insert(0, str(ROOT / "examples"))


@pytest.fixture(scope="session")
def justin():
    return load_points_cell(JUSTIN_CELL)


@pytest.fixture(scope="session")
def justin_positions_file(tmp_path_factory):
    if not JUSTIN_DATA.is_file():
        pytest.skip(f"DLR's Agile Justin data set is not at {JUSTIN_DATA} (download dataset/measurements.csv of dlr-alr/dlr-elastic-calibration)")
    import justin_positions

    target = tmp_path_factory.mktemp("justin") / "positions.csv"
    justin_positions.convert(str(JUSTIN_DATA), str(target))
    return target


def simulated(cell, rung: str, rng: np.random.Generator, n: int, *, noise: float = 2e-4):
    """Positions simulated by the model itself with parameters drawn from the priors; returns (truth, joints, xyz)."""
    from bayescal.kinematics import PointModel

    model = PointModel(cell, rung)
    truth = model.mean + model.sd * rng.standard_normal(model.size)
    joints = rng.uniform(-1.5, 1.5, size=(n, len(cell.commanded)))
    joints[:, -2:] = 0.0
    xyz, _ = model.predict(truth, cell.model_configuration(joints), jacobian=False)
    return model, truth, joints, xyz + noise * rng.standard_normal(xyz.shape)


def write_positions(path: Path, cell, joints: np.ndarray, xyz: np.ndarray) -> Path:
    """A positions file of ``joints`` (rad) and ``xyz`` (m) for ``cell``."""
    rows = [",".join(cell.joint_columns + ("marker", "x_mm", "y_mm", "z_mm"))]
    for q, points in zip(joints, xyz):
        angles = ",".join(f"{v:.10f}" for v in np.degrees(q))
        for marker, point in zip(cell.marker_names, points):
            rows.append(f"{angles},{marker}," + ",".join(f"{1000 * v:.6f}" for v in point))
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


__all__ = ["JUSTIN_CELL", "JUSTIN_DATA", "KinematicCalibration", "simulated", "write_positions"]
