"""Fitting a joint's axis in the tracker frame from the circles its reflectors draw.

Every reflector carried by joint ``j`` moves on a circle about the joint's axis
with the joint angle known: eq 10 of Klimchik et al. in 3D, as in
:func:`bayescal.geometry.arcs.known_angle_fit`, but with all reflectors sharing
one axis.  Reading ``i`` of reflector ``k`` is modelled as

    p_i = c + h_k a + r_k (cos(q_i + φ_k) e1 + sin(q_i + φ_k) e2) + ε_i,   ε_i ~ N(0, σ(p_i)² I) at least,

with ``a`` the unit axis (right-handed with increasing ``q``), ``c`` the point on
it nearest the tracker origin, ``e1, e2`` a fixed orthonormal pair
perpendicular to ``a``, and a height ``h_k``, radius ``r_k`` and phase ``φ_k`` per
reflector (reflectors sit at different azimuths, so each has its own phase).

**The noise is learned.**  ``σ(p)`` is the tracker's distance-dependent law (the
cell's ``[tracker]``); a real cell scatters more than its tracker's datasheet
(the reflector's seating, the joint's wobble and transmission error, air), so the
joint's arcs carry an excess ``s = max(1, χ²/dof)^½`` over it, one per joint, which
:func:`span_needed` and the output use.

**The readings of one angle share errors** (the joint's wobble and transmission
error there), so the covariance is clustered by swept angle
(:mod:`bayescal.registration.robust`: bias-reduced, with its small-sample degrees
of freedom); the Laplace one at the tracker's law stands only in a direction the
sandwich does not see (a sweep of fewer angles than the axis has parameters).
With a sweep's 5-12 angles the sandwich is noisy and a component's error over its
sd has Student-t tails: the intervals with the normal's ±1/2/3σ coverage are
``±t_ν(Φ(k))`` sd (:meth:`AxisFit.half_widths`), ``ν`` Bell and McCaffrey's
(about 3.4 with 7 angles).  Measured in docs/registration.md, on the independent
cell generator (noise 3-10 times the law) and on the twin's sweeps at the law.

**A label is judged by evidence.**  A reflector is called mislabelled only when
relabelling some readings (the reflectors' names permuted at one angle, or one
reading given another's name) explains the sweep better by more than
:data:`LABEL_GAIN` nats of profile likelihood (:func:`relabel_evidence`);
otherwise its misfit is what it is, learned as the joint's excess.

**A sweep too short to bend its arcs beyond the noise determines no axis**
(:func:`span_needed`): the fit of a nearly straight arc falls into a wrong minimum
with a small reported sd.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError
from bayescal.geometry.arcs import known_angle_fit
from bayescal.registration.robust import clustered_covariance, combined_dof, interval_factor, sandwich_dof, unseen_at_floor
from bayescal.registration.sweeps import Sweeps
from bayescal.units import DEG, MM

__all__ = ["AxisFit", "INTERVAL_NOTE", "AxisStart", "axis_start", "fit_axis", "relabel_evidence", "span_needed", "LABEL_GAIN", "MIN_BENDING", "SCATTER_LEVEL"]

LABEL_GAIN = 25.0
"""Nats by which relabelling some readings must explain a sweep better before a reflector is called mislabelled:
the critique's decisive gain (:data:`bayescal.critique.rule.DECISIVE_GAIN`).  On the independent cell generator
(noise 3-10 times the tracker's law, one reflector 5 times noisier or not; docs/registration.md) no relabelling of an
honest sweep gains anything (200 files), while two reflectors swapped at one angle gain 30 nats at the least."""

MIN_BENDING = 8.0
"""Fewest noise sds by which the farthest reflector's arc must bend away from its chord (its sagitta) for the
sweep to determine the axis.  Measured on 96 files of the independent cell generator (joints 1 and 2, spans of
0.5-20°, noise 1, 3 or 10 times the tracker's law, seed 1), the sagitta over the learned noise: below 4 sd, 41 of 75
axes were off by more than 4 of their sd (up to 10¹² sd); from 4 to 8, 1 of 17; from 8 up, 1 of 100."""

SCATTER_LEVEL = 1e-3
"""The arcs are said to scatter beyond the tracker's law when their χ² exceeds its upper quantile at this level
(χ² with the fit's degrees of freedom): a sweep read as the datasheet says is told so once in a thousand."""

_REFITTED = 3
"""Relabellings refitted at each step of the search, those that fit best at the current parameters.  Measured on 80
files of the independent cell generator: the same gains as refitting every permutation of every angle, at 0.26
instead of 3.2 s per file."""
_SAME_ANGLE = 1e-6 * DEG
"""Angles closer than this (rad) are one angle of the sweep: below any controller's resolution."""


INTERVAL_NOTE = ("±k sd: the sd times Student's t quantile at the normal's ±k sd coverage (68.3 / 95.4 / 99.7 %) with "
                 "the sd's degrees of freedom (dof; null: a normal's)")
"""How the registration's intervals are made, as its output says."""


def _finite_or_none(value: float) -> float | None:
    """``value``, or None for infinity (which JSON cannot hold)."""
    return float(value) if np.isfinite(value) else None


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
        (6, 6) covariance of ``[direction, point]`` (rank 4), m and 1: the one clustered by swept angle
        (``sandwich``), the Laplace one at the tracker's law in any direction the sandwich does not see.
    reflectors
        Per reflector: ``radius_mm``, ``height_mm`` (along the axis from ``point``),
        ``phase_deg``, ``rms_mm``, ``z_rms`` (rms residual over the tracker's law).
    residual_rms
        Root mean square of the residual vectors' lengths, m.
    chi2
        Sum of squared residuals over the tracker's law (not the learned noise).
    dof
        Degrees of freedom: ``3n`` minus the parameters.
    sandwich
        (6, 6) the covariance clustered by swept angle (:func:`~bayescal.registration.robust.clustered_covariance`).
    dof_kernel
        (G, 3n, 6) its degrees-of-freedom kernel for contrasts of ``[direction, point]``
        (:func:`~bayescal.registration.robust.sandwich_dof`), G the swept angles.
    """

    joint: int
    direction: np.ndarray
    point: np.ndarray
    cov: np.ndarray
    reflectors: pd.DataFrame
    residual_rms: float
    chi2: float
    dof: int
    sandwich: np.ndarray
    dof_kernel: np.ndarray

    def interval_dof(self, contrast: np.ndarray) -> float:
        """Degrees of freedom of the sd of ``contrast @ [direction, point]`` (``contrast`` (6,)): the sandwich's, by
        Welch and Satterthwaite where the tracker's law stands in for it (``inf`` where the law alone sets the sd)."""
        part = float(contrast @ self.sandwich @ contrast)
        return combined_dof(float(contrast @ self.cov @ contrast), [(part, sandwich_dof(self.dof_kernel, contrast))])

    def _across_dof(self, block: slice) -> float:
        """The smaller degrees of freedom of the two principal components of ``block`` of ``cov`` (across the axis)."""
        values, vectors = np.linalg.eigh(self.cov[block, block])
        dofs = []
        for v in vectors[:, values > values.max() * 1e-9].T:
            contrast = np.zeros(6)
            contrast[block] = v
            dofs.append(self.interval_dof(contrast))
        return min(dofs)

    @property
    def direction_dof(self) -> float:
        """Degrees of freedom of the direction's sd (the smaller of its two components'): its intervals' t quantiles."""
        return self._across_dof(slice(0, 3))

    @property
    def point_dof(self) -> float:
        """Degrees of freedom of the point's sd across the axis (the smaller of its two components')."""
        return self._across_dof(slice(3, 6))

    def half_widths(self) -> dict[str, dict[str, float]]:
        """Half-widths of the intervals with the normal's ±1/2/3 sd coverage, from the rms sds and Student-t
        quantiles at :attr:`direction_dof` and :attr:`point_dof`: ``{"direction_mrad": {"1": …}, "point_mm": …}``."""
        return {"direction_mrad": {str(k): float(interval_factor(k, self.direction_dof) * self.direction_sd * 1e3) for k in (1, 2, 3)},
                "point_mm": {str(k): float(interval_factor(k, self.point_dof) * self.point_sd / MM) for k in (1, 2, 3)}}

    @property
    def direction_sd(self) -> float:
        """Standard deviation of the axis direction, rad (rms of its two tilt components)."""
        return float(np.sqrt(np.trace(self.cov[:3, :3]) / 2))

    @property
    def point_sd(self) -> float:
        """Standard deviation of the axis point across the axis, m (rms of its two components)."""
        return float(np.sqrt(np.trace(self.cov[3:, 3:]) / 2))

    @property
    def chi2_per_dof(self) -> float:
        """χ²/dof against the tracker's law: about 1 when the cell scatters as its tracker's datasheet says."""
        return self.chi2 / max(self.dof, 1)

    @property
    def scatter(self) -> float:
        """The arcs' scatter over the tracker's law, ``sqrt(χ²/dof)``."""
        return float(np.sqrt(self.chi2_per_dof))

    @property
    def excess(self) -> float:
        """The noise learned from the arcs over the tracker's law, ``max(1, χ²/dof)^½``: the factor in the axis's sd."""
        return max(1.0, self.scatter)

    @property
    def beyond_tracker(self) -> bool:
        """Whether χ² exceeds its upper :data:`SCATTER_LEVEL` quantile under the tracker's law."""
        from scipy.stats import chi2

        return bool(self.chi2 > chi2.isf(SCATTER_LEVEL, max(self.dof, 1)))

    def summary(self) -> pd.DataFrame:
        """One row: the axis, its uncertainty (mrad, mm), the arc residual rms (mm), χ²/dof and the scatter."""
        return pd.DataFrame([{
            "joint": self.joint + 1,
            **{f"a{c}": v for c, v in zip("xyz", self.direction)},
            **{f"{c}_mm": v / MM for c, v in zip("xyz", self.point)},
            "direction_sd_mrad": self.direction_sd * 1e3,
            "point_sd_mm": self.point_sd / MM,
            "rms_mm": self.residual_rms / MM,
            "chi2_per_dof": self.chi2_per_dof,
            "scatter_over_tracker": self.scatter,
            "excess_over_tracker": self.excess,
            "direction_dof": self.direction_dof,
            "point_dof": self.point_dof,
        }])

    def diagnostics(self) -> pd.DataFrame:
        """Per reflector: radius, height, phase, residual rms and rms over the tracker's law."""
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
            "scatter_over_tracker": self.scatter,
            "excess_over_tracker": self.excess,
            # JSON has no infinity: null is a normal's interval (the tracker's law alone sets the sd).
            "direction_dof": _finite_or_none(self.direction_dof),
            "point_dof": _finite_or_none(self.point_dof),
            "half_width": self.half_widths(),
            "interval": INTERVAL_NOTE,
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


def _model(x: np.ndarray, start: AxisStart, index: np.ndarray) -> np.ndarray:
    """(n, 3) readings the circle model predicts (m) at parameters ``x``, reflector ``index`` of each reading."""
    a, c = _unpack(x[:4], *start.frame)
    e1, e2 = _perpendicular(a)
    h, r, phi = x[4::3][index], x[5::3][index], x[6::3][index]
    q = start.q
    return c + h[:, None] * a + r[:, None] * (np.cos(q + phi)[:, None] * e1 + np.sin(q + phi)[:, None] * e2)


def _solve(start: AxisStart, index: np.ndarray, sigma: np.ndarray, x0: np.ndarray):
    """Weighted least squares of the circle model, each reading's noise sd ``sigma`` (n,) m."""
    # imported here: the registration package is loaded by every campaign critique (its drift evidence), which
    # never fits an axis, and SciPy's optimiser is a tenth of that command's start-up
    from scipy.optimize import least_squares

    return least_squares(lambda x: ((_model(x, start, index) - start.xyz) / sigma[:, None]).ravel(), x0,
                         method="lm", x_scale="jac")


def _profile(chi2: float, n: int) -> float:
    """Log-likelihood (nats, constants dropped) of residuals whose sum of squares over the tracker's law is ``chi2``
    over ``n`` numbers, with one excess shared by them profiled out at its estimate, the datasheet a lower bound."""
    s2 = max(1.0, chi2 / n)
    return -0.5 * n * np.log(s2) - 0.5 * chi2 / s2


def relabel_evidence(start: AxisStart, sigma: np.ndarray, fit) -> tuple[float, np.ndarray]:
    """The gain (nats) of the best relabelling of the sweep, and the reflector (into ``start.names``) it gives each reading.

    A relabelling changes readings not yet changed: the names of all readings of one angle permuted (two reflectors
    swapped), or one reading given another reflector's name.  Greedy: at each step the relabelling that raises the
    profile likelihood (one excess over the tracker's law for the whole sweep) most, while any does; the gain is that
    of all the steps.  Each step refits the :data:`_REFITTED` relabellings that fit best at the current parameters.
    """
    count = len(start.names)
    keys = np.round(start.q / _SAME_ANGLE).astype(np.int64)
    n = start.xyz.size
    index, x = start.index.copy(), fit.x
    best = _profile(float(np.sum(fit.fun**2)), n)
    original = best
    permutations = [np.array(p) for p in itertools.permutations(range(count)) if p != tuple(range(count))]
    while permutations:
        free = index == start.index
        trials = []
        for key in np.unique(keys):
            rows = keys == key
            if not free[rows].all():
                continue
            for p in permutations:
                trial = index.copy()
                trial[rows] = p[index[rows]]
                trials.append(trial)
        for row in np.flatnonzero(free):
            for k in range(count):
                if k != index[row]:
                    trial = index.copy()
                    trial[row] = k
                    trials.append(trial)
        unfitted = [float(np.sum(((_model(x, start, trial) - start.xyz) / sigma[:, None]) ** 2)) for trial in trials]
        step = None
        for i in np.argsort(unfitted)[:_REFITTED]:
            candidate = _solve(start, trials[i], sigma, x)
            value = _profile(float(np.sum(candidate.fun**2)), n)
            if value > best and (step is None or value > step[0]):
                step = (value, trials[i], candidate.x)
        if step is None:
            break
        best, index, x = step
    return best - original, index


def _relabelled(start: AxisStart, sigma: np.ndarray, fit, sweep: Sweeps, joint: int) -> None:
    """Raise when relabelling some readings explains the sweep by more than :data:`LABEL_GAIN` nats."""
    gain, index = relabel_evidence(start, sigma, fit)
    if gain <= LABEL_GAIN:
        return
    rows = np.flatnonzero(index != start.index)
    lines = sweep.of(joint).line[rows]
    labelled = ", ".join(f"'{start.names[k]}'" for k in start.index[rows])
    fits_as = ", ".join(f"'{start.names[k]}'" for k in index[rows])
    raise InputError(
        f"the reading{'s' if rows.size > 1 else ''} on line{'s' if rows.size > 1 else ''} {', '.join(map(str, lines))} "
        f"labelled {labelled} fit{'' if rows.size > 1 else 's'} as {fits_as}: relabelling explains joint {joint + 1}'s "
        f"sweep better by {gain:.0f} nats (decisive above {LABEL_GAIN:g}); correct the marker column there, or leave "
        "the reflector out",
        source=sweep.source, line=int(lines[0]), column="marker",
    )


def span_needed(sweep: Sweeps, joint: int, noise: TrackerNoise, excess: float = 1.0) -> float | None:
    """The sweep's angle span (rad) needed to determine ``joint``'s axis, or None when the sweep bends enough.

    Each reflector's arc bends away from its chord by the sagitta ``(chord / 2) tan(Δ / 4)``, ``Δ`` its
    angle span; the axis is determined when the largest sagitta is :data:`MIN_BENDING` times that reflector's
    noise sd (the tracker's law times ``excess``).  Otherwise the span that would bend it so much,
    ``2 acos(1 - MIN_BENDING σ / r)`` with the radius ``r = chord / (2 sin(Δ / 2))`` (π when no span can).
    """
    s = sweep.of(joint)
    sigma = noise.sigma(s.xyz) * excess
    best, needed = 0.0, np.inf
    for name in dict.fromkeys(s.marker):
        rows = np.flatnonzero(s.marker == name)
        q = s.q[rows, joint]
        lo, hi = rows[np.argmin(q)], rows[np.argmax(q)]
        span = float(np.ptp(q))
        chord = float(np.linalg.norm(s.xyz[hi] - s.xyz[lo]))
        if span <= _SAME_ANGLE or span >= 2 * np.pi - _SAME_ANGLE:
            return None if span > np.pi else needed
        bending = 0.5 * chord * np.tan(span / 4) / float(np.median(sigma[rows]))
        best = max(best, bending)
        radius = chord / (2 * np.sin(span / 2))
        ratio = MIN_BENDING * float(np.median(sigma[rows])) / max(radius, 1e-12)
        needed = min(needed, 2 * np.arccos(1 - ratio) if ratio < 2 else 2 * np.pi)
    return None if best >= MIN_BENDING else float(min(needed, 2 * np.pi))


def fit_axis(sweep: Sweeps, joint: int, noise: TrackerNoise) -> AxisFit:
    """Fit the common axis of all reflectors of the sweep of ``joint`` (0-based), with the joint's learned excess noise.

    Parameters
    ----------
    sweep
        Readings; only those of ``joint``'s sweep are used.
    joint
        0-based joint index.
    noise
        The tracker's noise law, the lower bound of the arcs' noise; its ``position`` must be the tracker
        origin, i.e. zero, since the readings are in the tracker frame.

    Raises
    ------
    InputError
        Relabelling some readings explains the sweep decisively better (:data:`LABEL_GAIN`).
    """
    start = axis_start(sweep, joint)
    sigma = noise.sigma(start.xyz)
    fit = _solve(start, start.index, sigma, start.x0)
    _relabelled(start, sigma, fit, sweep, joint)
    return _result(fit, joint, start, sigma)


def _angle_clusters(q: np.ndarray) -> np.ndarray:
    """(n,) the swept angle of each reading as a cluster number: readings of one angle share the joint's wobble
    and transmission error there."""
    return np.unique(np.round(q / _SAME_ANGLE).astype(np.int64), return_inverse=True)[1]


def _result(fit, joint: int, start: AxisStart, sigma: np.ndarray) -> AxisFit:
    """Package the optimum: the covariance (in every direction the larger of the Laplace one with the learned excess
    and the one clustered by angle) pushed to (direction, point), and the per-reflector residuals."""
    index = start.index
    residual = _model(fit.x, start, index) - start.xyz
    z = residual / sigma[:, None]
    rows = []
    for k, name in enumerate(start.names):
        rows.append({"marker": name, "height_mm": fit.x[4 + 3 * k] / MM, "radius_mm": abs(fit.x[5 + 3 * k]) / MM,
                     "phase_deg": float(np.degrees(fit.x[6 + 3 * k])),
                     "rms_mm": float(np.sqrt(np.mean(np.sum(residual[index == k] ** 2, axis=1)))) / MM,
                     "z_rms": float(np.sqrt(np.mean(z[index == k] ** 2)))})
    chi2, dof = float(np.sum(z**2)), fit.fun.size - fit.x.size
    bread = np.linalg.pinv(fit.jac.T @ fit.jac)
    sandwich, kernel = clustered_covariance(fit.jac, fit.fun, bread, _angle_clusters(start.q))
    step, J = 1e-7, np.empty((6, 4))
    base = np.concatenate(_unpack(fit.x[:4], *start.frame))
    for i in range(4):
        dx = fit.x[:4].copy()
        dx[i] += step
        J[:, i] = (np.concatenate(_unpack(dx, *start.frame)) - base) / step
    # The sandwich alone, with its degrees of freedom: a floor at the tracker's law, where that law is the truth,
    # would widen the intervals (docs/registration.md); the law stands only where the sandwich sees nothing.
    cov = J @ unseen_at_floor(sandwich[:4, :4], bread[:4, :4]) @ J.T
    return AxisFit(joint, base[:3], base[3:], cov, pd.DataFrame(rows), float(np.sqrt(np.mean(np.sum(residual**2, axis=1)))),
                   chi2, dof, J @ sandwich[:4, :4] @ J.T, kernel[:, :, :4] @ J.T)
