"""Registering the tracker to the robot: every swept joint's axis and the robot's frames, in the tracker frame."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.errors import InputError
from bayescal.registration.axes import AxisFit, fit_axis
from bayescal.registration.frames import Frame, frames_with_uncertainty, urdf_axes
from bayescal.registration.sweeps import Sweeps
from bayescal.units import DEG, MM

__all__ = ["Registration", "read_frame", "register"]


@dataclass(frozen=True)
class Registration:
    """The axes of the swept joints and, when joints 1 and 2 were swept, the paper and base frames.

    Attributes
    ----------
    axes
        0-based joint index -> its :class:`AxisFit` (tracker frame).
    frames
        ``"paper"`` and ``"base"`` -> :class:`Frame` (empty without sweeps of joints 1 and 2).
    home
        (nq,) the joint angles the sweeps start from (the other joints' angles in each sweep), rad.
    source
        The sweep file.
    """

    axes: dict[int, AxisFit]
    frames: dict[str, Frame]
    home: np.ndarray
    source: str

    def summary(self) -> pd.DataFrame:
        """One row per swept joint: axis, its sd (mrad, mm), arc residual rms (mm)."""
        return pd.concat([fit.summary() for fit in self.axes.values()], ignore_index=True)

    def diagnostics(self) -> pd.DataFrame:
        """One row per joint and reflector: radius, height, phase, residual rms, standardised rms, and the fit's chi²/dof."""
        rows = []
        for j, fit in self.axes.items():
            table = fit.diagnostics()
            table.insert(0, "joint", j + 1)
            table["chi2_per_dof"] = fit.chi2 / max(fit.dof, 1)
            rows.append(table)
        return pd.concat(rows, ignore_index=True)

    def to_json(self) -> dict:
        """``{"axes": {"1": …}, "frames": {"paper": …, "base": …}, "home_deg": […], "source": …}``."""
        return {
            "axes": {str(j + 1): fit.to_json() for j, fit in self.axes.items()},
            "frames": {name: frame.to_json() for name, frame in self.frames.items()},
            "home_deg": (self.home / DEG).tolist(),
            "source": self.source,
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to a JSON file."""
        with open(path, "w", encoding="utf-8") as out:
            json.dump(self.to_json(), out, indent=2)



def _home(sweeps: Sweeps, nq: int) -> np.ndarray:
    """The home angles: each joint's angle in the sweeps of the other joints (all sweeps must share them)."""
    if sweeps.q.shape[1] != nq:
        raise InputError(f"expected {nq} joint-angle columns q1_deg … q{nq}_deg for the cell's robot, got {sweeps.q.shape[1]}",
                         source=sweeps.source, line=1)
    home = np.full(nq, np.nan)
    for j in sweeps.swept_joints:
        s = sweeps.of(j)
        for k in range(nq):
            if k == j:
                continue
            if np.isnan(home[k]):
                home[k] = s.q[0, k]
            elif abs(s.q[0, k] - home[k]) > 1e-6 * DEG:
                raise InputError(f"the sweep of joint {j + 1} starts from q{k + 1} = {s.q[0, k] / DEG:.6g} deg, the others "
                                 f"from {home[k] / DEG:.6g} deg: sweep every joint from one home pose",
                                 source=sweeps.source, line=int(s.line[0]), column=f"q{k + 1}_deg")
    # A joint moved in its own sweep only, and never held still elsewhere: its first angle stands for home.
    for j in range(nq):
        if np.isnan(home[j]):
            home[j] = sweeps.of(j).q[0, j] if j in sweeps.swept_joints else 0.0
    return home


def register(sweeps: Sweeps, cell: Cell, rng: np.random.Generator | int | None = 0, draws: int = 400) -> Registration:
    """Fit every swept joint's axis and, if joints 1 and 2 were swept, the paper and base frames.

    Parameters
    ----------
    sweeps
        The tracker-frame readings.
    cell
        Gives the tracker noise (taken at the tracker origin) and the robot's URDF.
    rng
        Seed or generator of the draws that propagate the axes' uncertainty to the frames.
    draws
        Number of such draws.
    """
    rng = np.random.default_rng(rng)
    noise = replace(cell.tracker, position=np.zeros(3))
    home = _home(sweeps, cell.robot.nq)
    axes = {j: fit_axis(sweeps, j, noise) for j in sweeps.swept_joints}
    frames: dict[str, Frame] = {}
    if 0 in axes and 1 in axes:
        nominal = urdf_axes(cell.robot, home)
        frames = {f.name: f for f in frames_with_uncertainty(axes[0], axes[1], nominal, rng, draws)}
    return Registration(axes, frames, home, sweeps.source)


def read_frame(path: str | PathLike[str], name: str) -> Frame:
    """The frame ``name`` (``"paper"`` or ``"base"``) of a registration file written by :meth:`Registration.save`.

    Raises
    ------
    InputError
        Not JSON, no such frame, or a rotation that is not a 3×3 rotation matrix (to 1e-6).
    """
    source = str(path)
    try:
        with open(path, encoding="utf-8") as file:
            data = json.load(file)
        entry = data["frames"][name]
        rotation = np.array(entry["rotation"], dtype=float)
        translation = np.array(entry["translation_mm"], dtype=float) * MM
        rotation_cov = np.array(entry["rotation_cov_mrad2"], dtype=float) * 1e-6
        translation_cov = np.array(entry["translation_cov_mm2"], dtype=float) * MM**2
    except OSError as error:
        raise InputError(f"cannot read the registration ({error.strerror})", source=source) from None
    except (ValueError, KeyError, TypeError) as error:
        raise InputError(f"expected a registration file from `bayescal axes -o` with a '{name}' frame "
                         f"(problem: {type(error).__name__} {error})", source=source) from None
    shapes = rotation.shape == (3, 3) and translation.shape == (3,) and rotation_cov.shape == translation_cov.shape == (3, 3)
    if not shapes or not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
        raise InputError(f"the '{name}' frame's rotation is not a 3×3 rotation matrix, or its translation not 3 numbers",
                         source=source)
    return Frame(name, rotation, translation, rotation_cov, translation_cov, str(entry.get("from_nominal", "")))
