"""The registration on sweeps with a real cell's error budget: its intervals' coverage and its label check.

Every file comes from the independent cell generator
(:mod:`bayescal.twin.independent.cell_sweeps`: the reflectors turned by its own
code, the tracker's noise 3-10 times the cell's law, reflector seating, axis
wobble, transmission error, readings dropped), joints 1 and 2 of the cell's robot
swept from :data:`HOME_DEG`, the tracker placed and turned at random.

* :func:`coverage_study`: each file registered; every component's error over its
  sd and the sd's degrees of freedom (axes 1 and 2 across the axis, the base
  frame's rotation and translation); :func:`coverage` the share within the
  Student-t intervals with the normal's ±1/2/3σ coverage.
* :func:`label_study`: each file twice, as generated and with two reflectors'
  names swapped at one angle of one joint (a real mislabel); the label check's
  gain (nats) on each, to compare with :data:`~bayescal.registration.axes.LABEL_GAIN`.
  With ``loose`` > 1 one reflector scatters that many times more (an honest,
  large scatter).
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import replace

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from bayescal.cell.config import Cell
from bayescal.registration.axes import _solve, axis_start, relabel_evidence
from bayescal.registration.register import register
from bayescal.registration.robust import interval_factor
from bayescal.registration.sweeps import Sweeps
from bayescal.design.parallel import seeded_map
from bayescal.twin.independent.cell_sweeps import cell_sweeps, swap_labels
from bayescal.units import DEG, MM

__all__ = ["HOME_DEG", "coverage_study", "label_study", "coverage"]

HOME_DEG = (0.0, -90.0, 90.0, 0.0, 45.0, 0.0)
"""Home pose of every generated sweep file (that of the registration's other studies)."""


def _as_sweeps(table: pd.DataFrame) -> Sweeps:
    """A generated sweep table in SI, each row's line its position in a file with a header."""
    q = table[[c for c in table.columns if c.startswith("q") and c.endswith("_deg")]].to_numpy() * DEG
    return Sweeps(table["joint"].to_numpy() - 1, q, table["marker"].to_numpy(dtype=str),
                  table[["x_mm", "y_mm", "z_mm"]].to_numpy() * MM, np.arange(2, len(table) + 2), "generated sweeps")


def _across(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across unit ``a``."""
    seed = np.eye(3)[int(np.argmin(np.abs(a)))]
    b1 = np.cross(a, seed) / np.linalg.norm(np.cross(a, seed))
    return b1, np.cross(a, b1)


def _coverage_one(index: int, rng: np.random.Generator, *, cell: Cell, draws: int, angles: int) -> dict:
    generated = cell_sweeps(cell, rng, home_deg=HOME_DEG, angles=angles)
    registration = register(_as_sweeps(generated.table), cell, rng=rng, draws=draws)
    row = {"seed": index, "noise_factor": generated.noise_factor}
    for j, (a, c) in generated.axes.items():
        fit = registration.axes[j]
        row[f"excess_{j + 1}"] = fit.excess
        for k, b in enumerate(_across(a)):
            # The nearest point moves along the axis too when the axis tilts: compared across the axis only.
            for name, error, block in (("direction", fit.direction - a, slice(0, 3)), ("point", fit.point - c, slice(3, 6))):
                contrast = np.zeros(6)
                contrast[block] = b
                row[f"z_{name}_{j + 1}{k}"] = b @ error / np.sqrt(contrast @ fit.cov @ contrast)
                row[f"dof_{name}_{j + 1}{k}"] = fit.interval_dof(contrast)
    frame = registration.frames["base"]
    R, t = generated.base
    turn = Rotation.from_matrix(frame.rotation @ R.T).as_rotvec() / np.sqrt(np.diag(frame.rotation_cov))
    shift = (frame.translation - t) / np.sqrt(np.diag(frame.translation_cov))
    for name, z, dof in (("rotation", turn, frame.rotation_dof), ("translation", shift, frame.translation_dof)):
        row |= {f"z_{name}_{c}": v for c, v in zip("xyz", z)} | {f"dof_{name}_{c}": v for c, v in zip("xyz", dof)}
    return row


def coverage_study(cell: Cell, files: int, seed: int = 2026, *, draws: int = 400, angles: int = 7,
                   executor: Executor | None = None) -> pd.DataFrame:
    """One row per generated file (``angles`` a sweep): its noise factor, each joint's learned excess, every component's
    standardised error (``z_…``) and its sd's degrees of freedom (``dof_…``)."""
    return pd.DataFrame(seeded_map(_coverage_one, range(files), seed, executor=executor, cell=cell, draws=draws, angles=angles))


def coverage(table: pd.DataFrame, group: str, *, student: bool = True) -> dict[int, float]:
    """Share of the components whose column starts with ``z_`` + ``group`` within their intervals with the normal's
    ±1/2/3 sd coverage: Student-t at each one's ``dof_`` column, or the normal's (``student=False``)."""
    columns = [c for c in table.columns if c.startswith(f"z_{group}")]
    z = np.abs(table[columns].to_numpy().ravel())
    dof = table[["dof_" + c[2:] for c in columns]].to_numpy().ravel() if student else np.full(z.size, np.inf)
    return {k: float(np.mean(z < interval_factor(k, dof))) for k in (1, 2, 3)}


def _gain(table: pd.DataFrame, joint: int, cell: Cell) -> float:
    sweeps = _as_sweeps(table)
    start = axis_start(sweeps, joint)
    sigma = replace(cell.tracker, position=np.zeros(3)).sigma(start.xyz)
    return relabel_evidence(start, sigma, _solve(start, start.index, sigma, start.x0))[0]


def _label_one(index: int, rng: np.random.Generator, *, cell: Cell, loose: float) -> dict:
    joint = int(rng.integers(2))
    generated = cell_sweeps(cell, rng, home_deg=HOME_DEG, joints=(joint,), loose=loose)
    return {"seed": index, "joint": joint + 1, "noise_factor": generated.noise_factor,
            "honest_nats": _gain(generated.table, joint, cell), "swapped_nats": _gain(swap_labels(generated.table, joint, rng), joint, cell)}


def label_study(cell: Cell, files: int, seed: int = 2026, *, loose: float = 1.0, executor: Executor | None = None) -> pd.DataFrame:
    """One row per generated file (one joint swept): the label check's gain on it as generated and with a swap."""
    return pd.DataFrame(seeded_map(_label_one, range(files), seed, executor=executor, cell=cell, loose=loose))
