"""What the arcs get wrong: each swept joint's circle model against its extensions, on held-out angles.

The registration's model (:mod:`bayescal.registration.axes`) takes every reading of
a sweep on a circle about one fixed axis at the joint angle the controller
reports.  A *candidate* is that model with one more physical effect, a few
parameters per joint:

* ``angle_scale``: the joint turns by ``(1 + ε)`` times the reported change
  (a gear ratio off by ε); ``q → q + ε (q - q_mid)``, ``q_mid`` the sweep's median angle;
* ``transmission``: a cyclic transmission error, ``q → q + Σ_h c_h cos(h q) + s_h sin(h q)``
  over the harmonics :data:`HARMONICS` of the joint angle;
* ``wobble``: the arc's plane tilting with the angle, every reading turned
  about the axis point by ``(q - q_mid) w`` with ``w`` across the axis (2 parameters);
* ``tracker_range``: the tracker's distances off by a constant ``δ``, every
  reading moved by ``δ`` along its line of sight.  A *scale* of the tracker's
  distances is not a candidate: a scale about the tracker maps every circle onto
  a circle about the same axis direction, so no sweep can tell it (a scale bar
  or a known length can); it leaves the axes' directions, and so the frames'
  rotations, as they are.

Each model is fitted with the cell's tracker noise (as the registration is) on
all angles but one and predicts the readings at the angle left out, with the
fit's parameter uncertainty added to the noise (a Gaussian predictive).  A
candidate is *named* when its gain in expected log predictive density over the
circle model, summed over the held-out angles, exceeds :data:`SWEEP_Z` standard
errors and :data:`SWEEP_FLOOR` nats, or, as in the campaign critique, the decisive gain
(:data:`~bayescal.critique.rule.DECISIVE_GAIN` nats) clear of one standard error
(:data:`~bayescal.critique.rule.DECISIVE_Z`): no gain within its standard error is named
(Vehtari, Gelman & Gabry 2017 for the standard error ``sqrt(K var(d))``, which
fails when the gain sits in one or two of a few angles); the thresholds are set
on the digital twin's clean sweeps and measured on the independent generator's
(``docs/registration.md``).  Each model's noise is learned, as the
registration's: the tracker's law times its own excess ``max(1, χ²/dof)^½`` on the
angles it was fitted to.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.stats import multivariate_normal

from bayescal.cell.tracker import TrackerNoise
from bayescal.critique.rule import DECISIVE_GAIN, DECISIVE_Z
from bayescal.registration.axes import axis_start
from bayescal.registration.sweeps import Sweeps
from bayescal.units import DEG, MM, UM

__all__ = ["CANDIDATES", "HARMONICS", "UNITS", "SWEEP_Z", "SWEEP_FLOOR", "JointCritique", "SweepCritique", "critique_sweeps"]

HARMONICS = (2, 3)
"""Harmonics of the joint angle in the ``transmission`` candidate.  The first is left out: over a
sweep of tens of degrees it is an offset (the reflectors' phases) and a scale (``angle_scale``)."""
CANDIDATES = {"angle_scale": 1, "transmission": 2 * len(HARMONICS), "wobble": 2, "tracker_range": 1}
"""Each candidate and its number of parameters per joint."""
SWEEP_Z = 2.0
"""Standard errors by which a candidate's held-out gain must be positive to be named."""
SWEEP_FLOOR = 4.0
"""Nats a candidate's held-out gain must exceed to be named.  Set on 100 clean sweep files of the digital twin
(joints 1 and 2, 9 angles over ±20°, tracker placed and turned at random, seed 2026): the largest gain of any
candidate was 4.4 nats, and the rule (2 SE and 4 nats) named one in 1 file of 100 (docs/registration.md)."""
_STEP = 1e-7
"""Relative finite-difference step of the predictions' Jacobian in the parameters."""


def _predict(x: np.ndarray, candidate: str | None, q: np.ndarray, index: np.ndarray, count: int, q_mid: float,
             frame) -> np.ndarray:
    """(B, n, 3) readings the model predicts (m) at (B, P) parameter vectors: the circle model's first, the candidate's last.

    Batched so that a finite-difference Jacobian is one call.  The axis is ``a0 + θ0 b1 + θ1 b2`` normalised and its
    point ``c0 + θ2 b1 + θ3 b2`` moved to the foot from the tracker origin, as in the registration's fit; the pair
    across the axis is built from the start's ``b1`` so that it turns smoothly with the axis.
    """
    a0, c0, b1, b2 = frame
    a = a0 + x[:, :1] * b1 + x[:, 1:2] * b2
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    c = c0 + x[:, 2:3] * b1 + x[:, 3:4] * b2
    c -= np.sum(c * a, axis=1, keepdims=True) * a
    e1 = b1 - np.sum(b1 * a, axis=1, keepdims=True) * a
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(a, e1)
    h, r, phi = x[:, 4 : 4 + 3 * count : 3][:, index], x[:, 5 : 5 + 3 * count : 3][:, index], x[:, 6 : 6 + 3 * count : 3][:, index]
    extra = x[:, 4 + 3 * count :]
    angle = np.broadcast_to(q, h.shape)
    if candidate == "angle_scale":
        angle = angle + extra[:, :1] * (q - q_mid)
    elif candidate == "transmission":
        for i, harmonic in enumerate(HARMONICS):
            angle = angle + extra[:, 2 * i, None] * np.cos(harmonic * q) + extra[:, 2 * i + 1, None] * np.sin(harmonic * q)
    cos, sin = np.cos(angle + phi)[..., None], np.sin(angle + phi)[..., None]
    p = c[:, None] + h[..., None] * a[:, None] + r[..., None] * (cos * e1[:, None] + sin * e2[:, None])
    if candidate == "wobble":
        w = extra[:, :1] * e1 + extra[:, 1:2] * e2
        p = p + (q - q_mid)[None, :, None] * np.cross(w[:, None], p - c[:, None])
    elif candidate == "tracker_range":
        p = p + extra[:, :1, None] * p / np.linalg.norm(p, axis=2, keepdims=True)
    return p


def _jacobian(f, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f`` at ``x`` (flattened) and its forward-difference Jacobian, from one batched call of ``f`` on (P + 1, P) points."""
    steps = _STEP * np.maximum(1.0, np.abs(x))
    values = f(np.vstack([x, x + np.diag(steps)])).reshape(x.size + 1, -1)
    return values[0], ((values[1:] - values[0]) / steps[:, None]).T


@dataclass(frozen=True)
class _Data:
    """One joint's sweep: angles (rad), reflector index, readings (m), their noise sd (m), the frame of the axis parameters."""

    q: np.ndarray
    index: np.ndarray
    xyz: np.ndarray
    sigma: np.ndarray
    count: int
    q_mid: float
    frame: tuple
    start: np.ndarray

    def _whitened(self, x: np.ndarray, candidate, keep) -> np.ndarray:
        p = _predict(np.atleast_2d(x), candidate, self.q[keep], self.index[keep], self.count, self.q_mid, self.frame)
        return ((p - self.xyz[keep]) / self.sigma[keep, None]).reshape(p.shape[0], -1)

    def fit(self, candidate: str | None, keep: np.ndarray, x0: np.ndarray):
        return least_squares(lambda x: self._whitened(x, candidate, keep)[0], x0, method="lm", x_scale="jac",
                             jac=lambda x: _jacobian(lambda X: self._whitened(X, candidate, keep), x)[1])

    def held_out_density(self, fit, candidate, held: np.ndarray) -> tuple[float, float]:
        """Log predictive density of the readings ``held`` and their sum of squared residuals (m²).

        The noise is the model's own learned excess over the tracker's law on the angles it was fitted to,
        ``max(1, χ²/dof)``, as the registration's (:mod:`bayescal.registration.axes`): a candidate that explains
        part of the scatter predicts with less of it.
        """
        excess2 = max(1.0, float(np.sum(fit.fun**2)) / max(fit.fun.size - fit.x.size, 1))
        cov_x = excess2 * np.linalg.pinv(fit.jac.T @ fit.jac)
        predicted, J = _jacobian(
            lambda X: _predict(X, candidate, self.q[held], self.index[held], self.count, self.q_mid, self.frame), fit.x)
        cov = excess2 * np.diag(np.repeat(self.sigma[held] ** 2, 3)) + J @ cov_x @ J.T
        observed = self.xyz[held].ravel()
        return float(multivariate_normal.logpdf(observed, predicted, cov)), float(np.sum((observed - predicted) ** 2))


def _data(sweep: Sweeps, joint: int, noise: TrackerNoise) -> _Data:
    """The sweep of ``joint`` set up for fitting, started at the circle model's own start."""
    start = axis_start(sweep, joint)
    q_mid = float(np.median(start.q))
    return _Data(start.q, start.index, start.xyz, noise.sigma(start.xyz), len(start.names), q_mid, start.frame, start.x0)


@dataclass(frozen=True)
class JointCritique:
    """The critique of one joint's sweep.

    Attributes
    ----------
    joint
        0-based joint index.
    angles
        Number of held-out angles.
    evidence
        One row per candidate: ``delta_elpd`` (nats), ``se``, ``named``, its estimate and unit,
        held-out rms (mm) of the circle model and of the candidate.
    """

    joint: int
    angles: int
    evidence: pd.DataFrame

    @property
    def causes(self) -> list[str]:
        """The named candidates, largest gain first."""
        named = self.evidence[self.evidence["named"]]
        return list(named.sort_values("delta_elpd", ascending=False).index)

    def to_json(self) -> dict:
        return {"joint": self.joint + 1, "held_out_angles": self.angles, "causes": self.causes,
                "evidence": {name: {k: (bool(v) if k == "named" else v) for k, v in row.items()}
                             for name, row in self.evidence.to_dict(orient="index").items()}}


def _size(candidate: str, extra: np.ndarray, q: np.ndarray) -> float:
    """The candidate's size in the unit :data:`UNITS` gives it, from its parameters ``extra``."""
    if candidate == "angle_scale":
        return float(extra[0] * 1e6)
    if candidate == "transmission":
        # Only the error's variation over the sweep: its mean is a shift of every reflector's phase.
        error = sum(extra[2 * i] * np.cos(h * q) + extra[2 * i + 1] * np.sin(h * q) for i, h in enumerate(HARMONICS))
        return float(np.std(error) / DEG * 3600)
    if candidate == "wobble":
        return float(np.hypot(*extra) * 1e3)
    return float(extra[0] / UM)


UNITS = {"angle_scale": "ppm", "transmission": "arcsec rms over the sweep", "wobble": "mrad per rad", "tracker_range": "um"}
"""The unit of each candidate's size."""


def _estimate(candidate: str, fit, count: int, q: np.ndarray) -> tuple[float, float]:
    """The candidate's size and its sd (delta method on the full-data fit's Laplace covariance)."""
    extra = fit.x[4 + 3 * count :]
    cov = np.linalg.pinv(fit.jac.T @ fit.jac)[4 + 3 * count :, 4 + 3 * count :]
    value = _size(candidate, extra, q)
    gradient = np.empty(extra.size)
    for i in range(extra.size):
        step = 1e-6 * max(np.sqrt(cov[i, i]), 1e-12)
        dx = extra.copy()
        dx[i] += step
        gradient[i] = (_size(candidate, dx, q) - value) / step
    return value, float(np.sqrt(max(gradient @ cov @ gradient, 0.0)))


def critique_joint(sweep: Sweeps, joint: int, noise: TrackerNoise) -> JointCritique:
    """Held out one angle at a time, the circle model of ``joint``'s sweep against each candidate."""
    data = _data(sweep, joint, noise)
    keys = np.round(data.q / (1e-6 * DEG)).astype(np.int64)
    angles = np.unique(keys)
    full = {None: data.fit(None, np.ones(keys.size, bool), data.start)}
    scores = {}
    for candidate in (None, *CANDIDATES):
        x0 = np.concatenate([full[None].x, np.zeros(CANDIDATES.get(candidate, 0))])
        if candidate is not None:
            full[candidate] = data.fit(candidate, np.ones(keys.size, bool), x0)
        folds = []
        for key in angles:
            held = keys == key
            fit = data.fit(candidate, ~held, full[candidate].x)
            folds.append(data.held_out_density(fit, candidate, held))
        scores[candidate] = np.array(folds)
    rows = {}
    n = keys.size
    for candidate in CANDIDATES:
        d = scores[candidate][:, 0] - scores[None][:, 0]
        gain, se = float(d.sum()), float(np.sqrt(d.size * d.var(ddof=1)))
        value, sd = _estimate(candidate, full[candidate], data.count, data.q)
        rows[candidate] = {
            "delta_elpd": gain, "se": se,
            "named": bool((gain > SWEEP_Z * se and gain > SWEEP_FLOOR) or (gain > DECISIVE_GAIN and gain > DECISIVE_Z * se)),
            "estimate": value, "estimate_sd": sd, "unit": UNITS[candidate],
            "rms_circle_mm": float(np.sqrt(scores[None][:, 1].sum() / (3 * n)) / MM),
            "rms_candidate_mm": float(np.sqrt(scores[candidate][:, 1].sum() / (3 * n)) / MM),
        }
    return JointCritique(joint, int(angles.size), pd.DataFrame.from_dict(rows, orient="index"))


@dataclass(frozen=True)
class SweepCritique:
    """The critique of every swept joint."""

    joints: dict[int, JointCritique]

    @property
    def verdict(self) -> str:
        """``"adequate"`` when no candidate is named for any joint, else ``"misfit"``."""
        return "misfit" if any(j.causes for j in self.joints.values()) else "adequate"

    def summary(self) -> pd.DataFrame:
        """One row per joint and candidate."""
        return pd.concat({j + 1: c.evidence for j, c in self.joints.items()}, names=["joint", "candidate"])

    def diagnostics(self) -> dict:
        """The verdict and the naming rule (ΔELPD over its SE and its floor in nats, or the decisive gain in nats)."""
        return {"verdict": self.verdict, "rule": {"z": SWEEP_Z, "floor_nats": SWEEP_FLOOR, "decisive_nats": DECISIVE_GAIN, "decisive_over_se": DECISIVE_Z}}

    def to_json(self) -> dict:
        return self.diagnostics() | {"joints": {str(j + 1): c.to_json() for j, c in self.joints.items()},
                                     "not_a_candidate": "a scale of the tracker's distances: it maps circles onto circles "
                                                        "about the same axis directions, which no sweep can tell"}

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to a JSON file."""
        with open(path, "w", encoding="utf-8") as out:
            json.dump(self.to_json(), out, indent=2)



def critique_sweeps(sweeps: Sweeps, noise: TrackerNoise) -> SweepCritique:
    """The critique of every swept joint; ``noise`` with its position at the tracker origin (readings in its frame)."""
    return SweepCritique({j: critique_joint(sweeps, j, noise) for j in sweeps.swept_joints})
