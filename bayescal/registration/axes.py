"""Fitting a joint's axis in the tracker frame from the circles its reflectors draw.

Every reflector carried by joint ``j`` moves on a circle about the joint's axis
with the joint angle known: eq 10 of Klimchik et al. in 3D, as in
:func:`bayescal.geometry.arcs.known_angle_fit`, but with all reflectors sharing
one axis.  Reading ``i`` of reflector ``k`` is modelled as

    p_i = c + h_k a + r_k (cos(q_i + φ_k) e1 + sin(q_i + φ_k) e2),

with ``a`` the unit axis (right-handed with increasing ``q``), ``c`` the point on
it nearest the tracker origin, ``e1, e2`` a fixed orthonormal pair
perpendicular to ``a``, and a height ``h_k``, radius ``r_k`` and phase ``φ_k`` per
reflector (reflectors sit at different azimuths, so each has its own phase).
Residuals are weighted by the tracker's distance-dependent noise; the
uncertainty is the Laplace (Gauss-Newton) approximation at the optimum.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.geometry.arcs import known_angle_fit
from bayescal.registration.sweeps import Sweeps
from bayescal.units import MM

__all__ = ["AxisFit", "AxisStart", "axis_start", "fit_axis", "MAX_REFLECTOR_Z"]

MAX_REFLECTOR_Z = 6.0
"""Largest rms standardised residual of one reflector taken as noise: far beyond
it the reflector does not share the axis (a mislabelled reflector)."""


@dataclass(frozen=True)
class AxisFit:
    """A joint's axis in the tracker frame, SI units.

    Attributes
    ----------
    joint
        0-based joint index.
    direction
        (3,) unit axis, right-handed with increasing joint angle.
    point
        (3,) point of the axis nearest the tracker origin, m.
    cov
        (6, 6) posterior covariance of ``[direction, point]`` (rank 4), m and 1.
    reflectors
        Per reflector: ``radius_mm``, ``height_mm`` (along the axis from ``point``),
        ``phase_deg``, ``rms_mm``, ``z_rms`` (rms standardised residual).
    residual_rms
        Root mean square of the residual vectors' lengths, m.
    chi2
        Sum of squared standardised residuals.
    dof
        Degrees of freedom: ``3n`` minus the parameters.
    """

    joint: int
    direction: np.ndarray
    point: np.ndarray
    cov: np.ndarray
    reflectors: pd.DataFrame
    residual_rms: float
    chi2: float
    dof: int

    @property
    def direction_sd(self) -> float:
        """Standard deviation of the axis direction, rad (rms of its two tilt components)."""
        return float(np.sqrt(np.trace(self.cov[:3, :3]) / 2))

    @property
    def point_sd(self) -> float:
        """Standard deviation of the axis point across the axis, m (rms of its two components)."""
        return float(np.sqrt(np.trace(self.cov[3:, 3:]) / 2))

    def summary(self) -> pd.DataFrame:
        """One row: the axis, its uncertainty (mrad, mm) and the arc residual rms (mm)."""
        return pd.DataFrame([{
            "joint": self.joint + 1,
            **{f"a{c}": v for c, v in zip("xyz", self.direction)},
            **{f"{c}_mm": v / MM for c, v in zip("xyz", self.point)},
            "direction_sd_mrad": self.direction_sd * 1e3,
            "point_sd_mm": self.point_sd / MM,
            "rms_mm": self.residual_rms / MM,
        }])

    def diagnostics(self) -> pd.DataFrame:
        """Per reflector: radius, height, phase, residual rms and standardised rms."""
        return self.reflectors.copy()

    def to_json(self) -> dict:
        """A JSON-ready dictionary with units in the keys."""
        return {
            "joint": self.joint + 1,
            "direction": self.direction.tolist(),
            "point_mm": (self.point / MM).tolist(),
            "direction_sd_mrad": self.direction_sd * 1e3,
            "point_sd_mm": self.point_sd / MM,
            "cov_direction": self.cov[:3, :3].tolist(),
            "cov_point_mm2": (self.cov[3:, 3:] / MM**2).tolist(),
            "rms_mm": self.residual_rms / MM,
            "chi2": self.chi2,
            "dof": self.dof,
            "reflectors": self.reflectors.to_dict(orient="records"),
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to a JSON file."""
        with open(path, "w", encoding="utf-8") as out:
            json.dump(self.to_json(), out, indent=2)


def _perpendicular(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal pair spanning the plane perpendicular to unit ``a``, chosen smoothly near ``a``."""
    seed = np.eye(3)[int(np.argmin(np.abs(a)))]
    e1 = seed - (seed @ a) * a
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


@dataclass(frozen=True)
class AxisStart:
    """One joint's sweep set up for the circle model of its axis, and the model's start (SI units).

    Attributes
    ----------
    names
        Reflector names, in the order of their first reading.
    index
        ``(n,)`` reflector of each reading (into ``names``).
    q
        ``(n,)`` the swept joint's angle at each reading (rad).
    xyz
        ``(n, 3)`` readings in the tracker frame (m).
    frame
        ``(a0, c0, b1, b2)``: the start's unit axis, its point nearest the tracker origin (m) and an orthonormal
        pair across it; the model's four axis parameters move the axis and its point along ``b1`` and ``b2``.
    x0
        ``(4 + 3 count,)`` the start: the four axis parameters at 0, then each reflector's height along the
        axis (m), radius (m) and phase at q = 0 (rad, circular mean over its readings).
    """

    names: list[str]
    index: np.ndarray
    q: np.ndarray
    xyz: np.ndarray
    frame: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    x0: np.ndarray


def axis_start(sweep: Sweeps, joint: int) -> AxisStart:
    """The circle model's start for ``joint``'s sweep (0-based): axis and point averaged over the reflectors'
    own known-angle circles, each reflector's height, radius and phase about that axis."""
    s = sweep.of(joint)
    names = list(dict.fromkeys(s.marker))
    index = np.array([names.index(m) for m in s.marker])
    q, xyz = s.q[:, joint], s.xyz
    fits = [known_angle_fit(q[index == k], xyz[index == k]) for k in range(len(names))]
    a0 = np.mean([f.axis for f in fits], axis=0)
    a0 = a0 / np.linalg.norm(a0)
    centre = np.mean([f.centre for f in fits], axis=0)
    c0 = centre - (centre @ a0) * a0
    b1, b2 = _perpendicular(a0)
    x0 = [0.0] * 4
    for k in range(len(names)):
        d = xyz[index == k] - c0
        radial = d - np.outer(d @ a0, a0)
        phase = np.arctan2(radial @ b2, radial @ b1) - q[index == k]
        x0 += [float(np.mean(d @ a0)), float(np.mean(np.linalg.norm(radial, axis=1))), float(np.angle(np.mean(np.exp(1j * phase))))]
    return AxisStart(names, index, q, xyz, (a0, c0, b1, b2), np.array(x0))


def _unpack(theta: np.ndarray, a0: np.ndarray, c0: np.ndarray, b1: np.ndarray, b2: np.ndarray):
    """Axis direction and nearest point from the 4 local axis parameters."""
    a = a0 + theta[0] * b1 + theta[1] * b2
    a /= np.linalg.norm(a)
    c = c0 + theta[2] * b1 + theta[3] * b2
    return a, c - (c @ a) * a


def fit_axis(sweep: Sweeps, joint: int, noise: TrackerNoise) -> AxisFit:
    """Fit the common axis of all reflectors of the sweep of ``joint`` (0-based).

    Parameters
    ----------
    sweep
        Readings; only those of ``joint``'s sweep are used.
    joint
        0-based joint index.
    noise
        The tracker's noise; its ``position`` must be the tracker origin, i.e. zero,
        since the readings are in the tracker frame.

    Raises
    ------
    InputError
        A reflector whose rms standardised residual exceeds :data:`MAX_REFLECTOR_Z`:
        it does not share the axis of the others (mislabelled or loose).
    """
    start = axis_start(sweep, joint)
    index, q, xyz = start.index, start.q, start.xyz
    sigma = noise.sigma(xyz)

    def model(x: np.ndarray) -> np.ndarray:
        a, c = _unpack(x[:4], *start.frame)
        e1, e2 = _perpendicular(a)
        h, r, phi = x[4::3][index], x[5::3][index], x[6::3][index]
        return c + h[:, None] * a + r[:, None] * (np.cos(q + phi)[:, None] * e1 + np.sin(q + phi)[:, None] * e2)

    fit = least_squares(lambda x: ((model(x) - xyz) / sigma[:, None]).ravel(), start.x0, method="lm", x_scale="jac")
    return _result(fit, joint, start.names, index, xyz, model, sweep.of(joint), start.frame)


def _result(fit, joint, names, index, xyz, model, s: Sweeps, frame) -> AxisFit:
    """Package the optimum: Laplace covariance pushed to (direction, point), per-reflector checks."""
    z = fit.fun.reshape(-1, 3)
    residual = model(fit.x) - xyz
    rows = []
    for k, name in enumerate(names):
        zk = float(np.sqrt(np.mean(z[index == k] ** 2)))
        if zk > MAX_REFLECTOR_Z:
            raise InputError(
                f"reflector '{name}' does not share the axis of joint {joint + 1} with the others: its rms "
                f"standardised residual is {zk:.3g}, expected about 1 (at most {MAX_REFLECTOR_Z:g}); mislabelled reflector?",
                source=s.source, line=int(s.line[np.flatnonzero(index == k)[0]]), column="marker",
            )
        rows.append({"marker": name, "height_mm": fit.x[4 + 3 * k] / MM, "radius_mm": abs(fit.x[5 + 3 * k]) / MM,
                     "phase_deg": float(np.degrees(fit.x[6 + 3 * k])),
                     "rms_mm": float(np.sqrt(np.mean(np.sum(residual[index == k] ** 2, axis=1)))) / MM, "z_rms": zk})
    cov_x = np.linalg.pinv(fit.jac.T @ fit.jac)[:4, :4]
    step, J = 1e-7, np.empty((6, 4))
    base = np.concatenate(_unpack(fit.x[:4], *frame))
    for i in range(4):
        dx = fit.x[:4].copy()
        dx[i] += step
        J[:, i] = (np.concatenate(_unpack(dx, *frame)) - base) / step
    return AxisFit(
        joint, base[:3], base[3:], J @ cov_x @ J.T, pd.DataFrame(rows),
        float(np.sqrt(np.mean(np.sum(residual**2, axis=1)))), float(np.sum(fit.fun**2)), fit.fun.size - fit.x.size,
    )
