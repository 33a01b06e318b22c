"""``bayescal kinematics`` and ``predict`` on Agile Justin: the full model's fit and 10,000 predictions.

The fit runs on DLR's 500 measured configurations where the data set is at
``../shared/data/dlr-justin`` beside the repository, otherwise on 500
configurations of the independent point generator.  The predictions (positions and
predictive covariances of 10,000 random configurations) are timed against the
rigid joint frames computed by Pinocchio's ``forwardKinematics`` one configuration
at a time, in this process (the batched tree also computes the deflections; the
covariances, ``J Σ Jᵀ`` over every parameter, take most of the time).
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))

from bayescal.kinematics import KinematicCalibration, Positions, load_points_cell, read_positions  # noqa: E402
from bayescal.twin.independent import points as independent  # noqa: E402
from smoke import SMOKE, sized  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "dlr-justin" / "measurements.csv"
PREDICTIONS = sized(10_000, 20)
GENERATED = sized(500, 20)
"""Configurations of the independent generator fitted where DLR's data set is absent (always at the smoke size)."""


def _positions(cell, tmp: Path) -> tuple[Positions, str]:
    if DATA.is_file() and not SMOKE:
        import justin_positions

        justin_positions.convert(str(DATA), str(tmp / "positions.csv"))
        return read_positions(tmp / "positions.csv", cell), "DLR's 500 measured configurations"
    rng = np.random.default_rng(0)
    joints = independent.configurations(rng, GENERATED)
    xyz = independent.marker_positions(independent.draw_world(rng), joints, noise_rng=rng)
    n, m = xyz.shape[:2]
    return Positions(joints, xyz, np.zeros((n, m), int), np.arange(n * m).reshape(n, m)), f"{GENERATED} configurations of the independent generator"


def main() -> None:
    import tempfile

    cell = load_points_cell(ROOT / "data" / "robots" / "justin.toml")
    with tempfile.TemporaryDirectory() as folder:
        positions, what = _positions(cell, Path(folder))
    start = time.perf_counter()
    results = KinematicCalibration(cell, "full").fit(positions)
    fit_seconds = time.perf_counter() - start
    print(f"kinematics, full model, {what}: {fit_seconds:.1f} s ({results.diagnostics()['iterations']} steps)")

    joints = np.random.default_rng(1).uniform(-1.5, 1.5, size=(PREDICTIONS, len(cell.commanded)))
    start = time.perf_counter()
    mean, _ = results.predict(joints)
    batched = time.perf_counter() - start
    model = cell.tree.model.copy()
    for j, delta in results.model._corrections(results.mean).items():
        model.jointPlacements[j] = model.jointPlacements[j] * pin.exp6(delta)
    data = model.createData()
    q = cell.model_configuration(joints)
    start = time.perf_counter()
    results.model.predict(results.mean, q, jacobian=False)
    positions_only = time.perf_counter() - start
    start = time.perf_counter()
    for row in q:
        pin.forwardKinematics(model, data, row)
    loop = time.perf_counter() - start
    print(f"predict, {PREDICTIONS} configurations with predictive covariances: {batched:.2f} s")
    print(f"  positions only (batched tree with the deflections): {positions_only:.3f} s; Pinocchio's rigid forward kinematics, "
          f"one configuration a call: {loop:.3f} s (ratio {positions_only / loop:.2f})")


if __name__ == "__main__":
    main()
