"""The geometry critique's least-squares layout model: every candidate extension fitted to marker points.

A :class:`_Spec` names the extensions of a candidate; :func:`_fit` fits its
parameters to points by least squares (the lever step, then the cylinder
markers, or jointly with ``closed_loop``), with one noise level per marker group,
and returns a :class:`LayoutFit` that predicts every marker at any q2 through
the one marker-layout model (:mod:`bayescal.geometry.layout`).  The model and its
extensions are described in :mod:`bayescal.critique.geometry`, which compares
them on held-out angles.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from bayescal.geometry.arcs import LEVER_MARKER, MarkerPoints, concentric_fit, known_angle_fit
from bayescal.geometry.layout import (
    circular_mean,
    cylinder_direction,
    cylinder_points,
    lever_angle,
    lever_points,
    marker_offset,
)
from bayescal.units import DEG, MM, UM

__all__ = ["JACOBIAN_STEP", "JOINT_ITERATIONS", "LayoutFit", "MIN_DOF"]

MIN_DOF = 2
"""Fewest degrees of freedom a marker group's noise may be left with (its level then rests on at least
two residual coordinates' worth of scatter). A candidate that leaves fewer in some fold is not tried."""
JOINT_ITERATIONS = 3
"""Reweightings of the joint fit by the groups' noise levels: on Table I (slip, tilt, jointly) the levels
move by 6e-5 of themselves from the first to the second and by 1e-6 from the second to the third, then not at all."""
JACOBIAN_STEP = 1e-7
"""Central-difference step (m, rad or dimensionless) of the predictions' Jacobian.  On Table I the
Jacobian with steps of 1e-6 and 1e-8 differs from this one by 1e-9 and 8e-9 of its largest entry."""

_GROUPS = ("lever", "cylinder")
@dataclass(frozen=True)
class _Spec:
    """A model: its extensions (and probe) and whether it is fitted in two steps or jointly."""

    extensions: tuple[str, ...] = ()
    probe: str | None = None

    @property
    def joint(self) -> bool:
        return "closed_loop" in self.extensions

    def plus(self, extension: str) -> _Spec:
        return _Spec(self.extensions + (extension,), self.probe)

    def with_probe(self, probe: str) -> _Spec:
        return _Spec(self.extensions, probe)

    def names(self, cylinder: Sequence[str]) -> tuple[list[str], list[str]]:
        """Parameter names of the lever step and of the cylinder step."""
        lever = ["p2_x", "p2_y", "L", "phi"]
        rest = ["p0_x", "p0_y", *(f"R[{m}]" for m in cylinder), *(f"delta[{m}]" for m in cylinder)]
        if "tilt" in self.extensions:
            lever += ["tilt_a", "tilt_b"]
        if "joint_scale" in self.extensions:
            lever += ["joint_scale"]
        if "pivot_motion" in self.extensions:
            rest += ["pivot_gx", "pivot_gy"]
        if "cylinder_slip" in self.extensions:
            rest += ["slip_radius", "slip_angle"]
        if self.probe is not None:
            lever += ["probe_lever_radial", "probe_lever_tangential"]
            rest += ["probe_cylinder_radial", "probe_cylinder_tangential"]
        return lever, rest


def _predict(theta: dict[str, float], q2: np.ndarray, marker: np.ndarray, sense: int, probe_z: np.ndarray | None) -> np.ndarray:
    """Predicted points (m), shape ``(n, 2)``, of markers ``marker`` at angles ``q2`` (rad)."""
    return _predict_many({name: np.array([value]) for name, value in theta.items()}, q2, marker, sense, probe_z)[0]


def _predict_many(
    theta: dict[str, np.ndarray], q2: np.ndarray, marker: np.ndarray, sense: int, probe_z: np.ndarray | None
) -> np.ndarray:
    """Predictions ``(m, n, 2)`` for ``m`` parameter sets at once (each parameter an ``(m,)`` array): the Jacobians' batch."""

    def get(name: str) -> np.ndarray | float:
        return theta[name][:, np.newaxis] if name in theta else 0.0

    p2_x, p2_y = get("p2_x"), get("p2_y")
    angle_of_lever = lever_angle(get("phi"), sense, q2, get("joint_scale"))
    lever_x, lever_y = lever_points(p2_x, p2_y, get("L"), angle_of_lever)
    x = np.zeros_like(lever_x)
    y = np.zeros_like(lever_y)
    is_lever = marker == LEVER_MARKER
    x[:, is_lever], y[:, is_lever] = lever_x[:, is_lever], lever_y[:, is_lever]
    if probe_z is not None:
        radial, tangential = get("probe_lever_radial"), get("probe_lever_tangential")
        c, s = np.cos(angle_of_lever), np.sin(angle_of_lever)
        x[:, is_lever] += (probe_z * (radial * c - tangential * s))[:, is_lever]
        y[:, is_lever] += (probe_z * (radial * s + tangential * c))[:, is_lever]
    if "p0_x" in theta and not np.all(is_lever):
        p0_x, p0_y = get("p0_x"), get("p0_y")
        extension = np.hypot(lever_x - p0_x, lever_y - p0_y) - np.hypot(p2_x - p0_x, p2_y - p0_y)
        pivot_x = p0_x + extension * get("pivot_gx")
        pivot_y = p0_y + extension * get("pivot_gy")
        direction = cylinder_direction(lever_x, lever_y, pivot_x, pivot_y)
        for name in np.unique(marker[~is_lever]):
            rows = marker == name
            radius = get(f"R[{name}]") + get("slip_radius") * extension[:, rows]
            turn = get("slip_angle") * extension[:, rows]
            x[:, rows], y[:, rows], angle = cylinder_points(pivot_x[:, rows], pivot_y[:, rows], direction[:, rows], radius, get(f"delta[{name}]"), turn)
            if probe_z is not None:
                c, s = np.cos(angle), np.sin(angle)
                radial, tangential = get("probe_cylinder_radial"), get("probe_cylinder_tangential")
                x[:, rows] += probe_z[rows] * (radial * c - tangential * s)
                y[:, rows] += probe_z[rows] * (radial * s + tangential * c)
    if "tilt_a" in theta:
        a, b = get("tilt_a"), get("tilt_b")
        dx, dy = x - p2_x, y - p2_y
        x, y = p2_x + (1 - a) * dx - b * dy, p2_y - b * dx + (1 + a) * dy
    return np.stack([x, y], axis=-1)


def _probe_covariate(name: str | None, q2: np.ndarray, reference: np.ndarray) -> np.ndarray | None:
    """The probe's covariate at ``q2``, standardised over the campaign's angles ``reference`` (rad)."""
    if name is None:
        return None
    if name == "q2":
        values, ref = q2, reference
    else:
        centre = reference.mean()
        values, ref = (q2 - centre) ** 2, (reference - centre) ** 2
    return (values - ref.mean()) / ref.std()


@dataclass(frozen=True)
class LayoutFit:
    """A marker-layout model fitted to points.

    Attributes
    ----------
    names : list of str
        Parameter names, the lever step's first.
    theta : numpy.ndarray
        ``(p,)`` estimates, SI (m, rad, dimensionless, m/m, rad/m).
    cov : numpy.ndarray
        ``(p, p)`` their linearised covariance.
    sigma : dict
        Noise sd (m) per marker group, ``lever`` and ``cylinder``.
    dof : dict
        Degrees of freedom of each group's noise.
    sense : int
        The lever arc's sense (-1 clockwise as on Table I).
    spec : _Spec
    probe_reference : numpy.ndarray
        The campaign's angles (rad) the probe covariate is standardised over.
    """

    names: list[str]
    theta: np.ndarray
    cov: np.ndarray
    sigma: dict[str, float]
    dof: dict[str, int]
    sense: int
    spec: _Spec
    probe_reference: np.ndarray

    def predict_with(self, theta: np.ndarray, q2: np.ndarray, marker: np.ndarray) -> np.ndarray:
        z = _probe_covariate(self.spec.probe, q2, self.probe_reference)
        return _predict(dict(zip(self.names, theta)), q2, marker, self.sense, z)

    def predict(self, q2: np.ndarray, marker: np.ndarray) -> np.ndarray:
        """Predicted points (m), ``(n, 2)``."""
        return self.predict_with(self.theta, q2, marker)

    def jacobian(self, q2: np.ndarray, marker: np.ndarray) -> np.ndarray:
        """``(2n, p)`` derivative of the flattened predictions by the parameters."""
        z = _probe_covariate(self.spec.probe, q2, self.probe_reference)
        return _jacobian(self.names, self.theta, lambda batch: _predict_many(batch, q2, marker, self.sense, z))

    def log_density(self, q2: np.ndarray, marker: np.ndarray, xy: np.ndarray) -> float:
        """Log predictive density of the points ``xy`` (m, ``(n, 2)``) of markers ``marker`` at ``q2``."""
        # Imported here: the campaign critique imports this module with the package and needs nothing of scipy.stats
        # (0.28 s of CPU to import, a fifth of its command).
        from scipy import stats

        mean = self.predict(q2, marker)
        J = self.jacobian(q2, marker).reshape(q2.size, 2, -1)
        total = 0.0
        for group, rows in _group_rows(marker).items():
            if not rows.any():
                continue
            Jg = J[rows].reshape(-1, self.theta.size)
            shape = self.sigma[group] ** 2 * np.eye(Jg.shape[0]) + Jg @ self.cov @ Jg.T
            total += stats.multivariate_t.logpdf(xy[rows].ravel(), loc=mean[rows].ravel(), shape=shape, df=self.dof[group])
        return float(total)

    def geometry(self) -> dict[str, float]:
        """``L_mm, a_x_mm, a_y_mm, phi_deg`` of the fitted layout in the compensator's plane, each with its linearised sd.

        The conventions of :class:`~bayescal.geometry.arcs.CompensatorGeometryModel` (y read as pointing
        down when the lever turns counter-clockwise).  With a tilt, the layout's lengths are those of the
        plane scaled by ``1 - r`` (``r = hypot(tilt_a, tilt_b)``, the isotropic part the projection's
        parametrisation leaves to them), to first order in ``r``; they are divided by it here.
        """
        flip = -1.0 if self.sense == 1 else 1.0

        def values(vector: np.ndarray) -> np.ndarray:
            theta = dict(zip(self.names, vector))
            scale = 1.0 / (1.0 - np.hypot(theta.get("tilt_a", 0.0), theta.get("tilt_b", 0.0)))
            return np.array(
                [
                    theta["L"] * scale / MM,
                    (theta["p2_x"] - theta["p0_x"]) * scale / MM,
                    flip * (theta["p2_y"] - theta["p0_y"]) * scale / MM,
                    flip * theta["phi"] / DEG,
                ]
            )

        steps = JACOBIAN_STEP * np.eye(self.theta.size)
        gradient = np.column_stack([(values(self.theta + step) - values(self.theta - step)) / (2 * JACOBIAN_STEP) for step in steps])
        sd = np.sqrt(np.diag(gradient @ self.cov @ gradient.T))
        out = {}
        for name, value, spread in zip(("L_mm", "a_x_mm", "a_y_mm", "phi_deg"), values(self.theta), sd):
            out[name] = float(value)
            out[name.replace("_mm", "_sd_mm").replace("_deg", "_sd_deg")] = float(spread)
        return out

    def extension_parameters(self) -> dict[str, float]:
        """The extensions' parameters and their linearised sd in reporting units (keys name the unit).

        ``tilt_deg`` and ``tilt_axis_deg`` (the in-plane axis, from the tracker's X, modulo 180°) with
        ``tilt_anisotropy = 1 - cos t``; ``joint_scale_pct``; ``pivot_shift_{x,y}_um_per_mm`` (pivot shift
        per mm of spring extension); ``slip_radius_um_per_mm`` and ``slip_angle_mdeg_per_mm``.
        """
        theta = dict(zip(self.names, self.theta))
        sd = dict(zip(self.names, np.sqrt(np.diag(self.cov))))
        out: dict[str, float] = {}
        if "tilt_a" in theta:
            a, b = theta["tilt_a"], theta["tilt_b"]
            amplitude = float(np.hypot(a, b))
            tilt = float(np.arccos(max(-1.0, 1.0 - 2.0 * amplitude)))
            out["tilt_deg"] = tilt / DEG
            # linearised: t = arccos(1 - 2 hypot(a, b))
            i, j = self.names.index("tilt_a"), self.names.index("tilt_b")
            gradient = 2.0 / np.sin(tilt) * np.array([a, b]) / amplitude if amplitude > 0 else np.zeros(2)
            out["tilt_sd_deg"] = float(np.sqrt(gradient @ self.cov[np.ix_([i, j], [i, j])] @ gradient) / DEG)
            # (a, b) points along twice the shortened direction; the tilt axis is across it.
            out["tilt_axis_deg"] = float((np.degrees(0.5 * np.arctan2(b, a)) + 90.0) % 180.0)
            out["tilt_anisotropy"] = 2.0 * amplitude
        if "joint_scale" in theta:
            out["joint_scale_pct"] = float(100.0 * theta["joint_scale"])
            out["joint_scale_sd_pct"] = float(100.0 * sd["joint_scale"])
        if "pivot_gx" in theta:
            for axis in ("x", "y"):
                key = f"pivot_g{axis}"
                out[f"pivot_shift_{axis}_um_per_mm"] = float(theta[key] * MM / UM)
                out[f"pivot_shift_{axis}_sd_um_per_mm"] = float(sd[key] * MM / UM)
        if "slip_radius" in theta:
            out["slip_radius_um_per_mm"] = float(theta["slip_radius"] * MM / UM)
            out["slip_radius_sd_um_per_mm"] = float(sd["slip_radius"] * MM / UM)
            out["slip_angle_mdeg_per_mm"] = float(theta["slip_angle"] * MM / DEG * 1e3)
            out["slip_angle_sd_mdeg_per_mm"] = float(sd["slip_angle"] * MM / DEG * 1e3)
        return out


def _jacobian(names: list[str], theta: np.ndarray, predict_many: Callable[[dict[str, np.ndarray]], np.ndarray]) -> np.ndarray:
    """``(2n, p)`` central-difference Jacobian of flattened predictions, all ``2p`` evaluations in one batch."""
    p = theta.size
    steps = JACOBIAN_STEP * np.eye(p)
    batch = np.vstack([theta + steps, theta - steps])
    values = predict_many({name: batch[:, j] for j, name in enumerate(names)})
    values = values.reshape(2 * p, -1)
    return ((values[:p] - values[p:]) / (2 * JACOBIAN_STEP)).T


def _group_rows(marker: np.ndarray) -> dict[str, np.ndarray]:
    lever = marker == LEVER_MARKER
    return {"lever": lever, "cylinder": ~lever}


def _start(points: MarkerPoints, spec: _Spec) -> tuple[dict[str, float], int]:
    """Closed-form start (eqs 10-24, offsets as circular means) and the lever's sense."""
    q1, p1 = points.of(LEVER_MARKER)
    lever = known_angle_fit(q1, p1[:, :2])
    cylinder = points.cylinder_markers
    concentric = concentric_fit({name: points.of(name)[1][:, :2] for name in cylinder})
    theta = {"p2_x": lever.centre[0], "p2_y": lever.centre[1], "L": lever.radius, "phi": lever.phi}
    theta |= {"p0_x": concentric.centre[0], "p0_y": concentric.centre[1]}
    for name in cylinder:
        q2, xyz = points.of(name)
        d_lever = lever.predict(q2) - concentric.centre
        direction = np.arctan2(d_lever[:, 1], d_lever[:, 0])
        relative = marker_offset(xyz[:, 0], xyz[:, 1], concentric.centre[0], concentric.centre[1], direction)
        theta[f"R[{name}]"] = concentric.radii[name]
        theta[f"delta[{name}]"] = circular_mean(relative)
    lever_names, rest = spec.names(cylinder)
    return {name: float(theta.get(name, 0.0)) for name in lever_names + rest}, lever.sense


def _fit(points: MarkerPoints, spec: _Spec, reference: np.ndarray) -> LayoutFit:
    """Fit ``spec`` to ``points``: in two steps (lever, then cylinder), or jointly once ``closed_loop`` is in."""
    start, sense = _start(points, spec)
    lever_names, rest = spec.names(points.cylinder_markers)
    names = lever_names + rest
    q2, marker, xy = points.q2, points.marker, points.xyz[:, :2]
    z = _probe_covariate(spec.probe, q2, reference)
    rows = _group_rows(marker)
    dof = {"lever": 2 * int(rows["lever"].sum()) - len(lever_names), "cylinder": 2 * int(rows["cylinder"].sum()) - len(rest)}
    if min(dof.values()) < MIN_DOF:
        raise _TooFewDegrees

    def residual(values: np.ndarray, free: list[str], fixed: dict[str, float], subset: np.ndarray) -> np.ndarray:
        theta = fixed | dict(zip(free, values))
        return (_predict(theta, q2[subset], marker[subset], sense, None if z is None else z[subset]) - xy[subset]).ravel()

    def jacobian(values: np.ndarray, free: list[str], fixed: dict[str, float], subset: np.ndarray) -> np.ndarray:
        m = 2 * len(free)
        constant = {name: np.full(m, value) for name, value in fixed.items()}
        z_subset = None if z is None else z[subset]
        return _jacobian(free, values, lambda batch: _predict_many(constant | batch, q2[subset], marker[subset], sense, z_subset))

    def solve(
        free: list[str], fixed: dict[str, float], subset: np.ndarray, x0: dict[str, float], weight: np.ndarray | None = None
    ) -> dict[str, float]:
        scale = 1.0 if weight is None else weight
        fixed = {name: value for name, value in fixed.items() if name not in free}
        solution = least_squares(
            lambda v: residual(v, free, fixed, subset) * scale,
            np.array([x0[name] for name in free]),
            jac=lambda v: jacobian(v, free, fixed, subset) * (scale if np.ndim(scale) == 0 else scale[:, np.newaxis]),
            method="lm",
            xtol=1e-12,
            ftol=1e-12,
        )
        return dict(zip(free, solution.x))

    theta = solve(lever_names, {name: start[name] for name in rest}, rows["lever"], start)
    theta |= solve(rest, theta, rows["cylinder"], start)
    sigma = _levels(theta, names, q2, marker, xy, sense, z, dof)
    if spec.joint:
        everything = np.ones(q2.size, dtype=bool)
        for _ in range(JOINT_ITERATIONS):
            weight = np.repeat(np.where(rows["lever"], 1.0 / sigma["lever"], 1.0 / sigma["cylinder"]), 2)
            theta = solve(names, {}, everything, theta, weight)
            sigma = _levels(theta, names, q2, marker, xy, sense, z, dof)
    vector = np.array([theta[name] for name in names])
    fitted = LayoutFit(names, vector, np.zeros((len(names), len(names))), sigma, dof, sense, spec, reference)
    J = fitted.jacobian(q2, marker).reshape(q2.size, 2, -1)
    J_lever = J[rows["lever"]].reshape(-1, len(names))
    J_cylinder = J[rows["cylinder"]].reshape(-1, len(names))
    cov = _covariance(J_lever, J_cylinder, sigma, len(lever_names), spec.joint)
    return LayoutFit(names, vector, cov, sigma, dof, sense, spec, reference)


class _TooFewDegrees(Exception):
    """A model with more parameters than its marker groups' points allow."""


def _levels(theta, names, q2, marker, xy, sense, z, dof) -> dict[str, float]:
    residual = _predict(theta, q2, marker, sense, z) - xy
    out = {}
    for group, rows in _group_rows(marker).items():
        out[group] = float(np.sqrt(np.sum(residual[rows] ** 2) / dof[group]))
    return out


def _covariance(J_lever: np.ndarray, J_cylinder: np.ndarray, sigma: dict[str, float], n_lever: int, joint: bool) -> np.ndarray:
    """Linearised covariance of the parameters (lever step's first).

    Jointly: the inverse of the weighted Gauss-Newton matrix.  In two steps: the
    lever step's covariance from P1 alone, and the cylinder step's conditional
    covariance plus the lever's propagated through ``dθ_cyl/dθ_lever``.
    """
    if joint:
        information = J_lever.T @ J_lever / sigma["lever"] ** 2 + J_cylinder.T @ J_cylinder / sigma["cylinder"] ** 2
        return np.linalg.pinv(information)
    p = J_lever.shape[1]
    A1 = J_lever[:, :n_lever]
    lever_cov = sigma["lever"] ** 2 * np.linalg.pinv(A1.T @ A1)
    A = J_cylinder[:, n_lever:]
    B = J_cylinder[:, :n_lever]
    inverse = np.linalg.pinv(A.T @ A)
    D = -inverse @ A.T @ B
    cov = np.zeros((p, p))
    cov[:n_lever, :n_lever] = lever_cov
    cov[n_lever:, n_lever:] = sigma["cylinder"] ** 2 * inverse + D @ lever_cov @ D.T
    cov[n_lever:, :n_lever] = D @ lever_cov
    cov[:n_lever, n_lever:] = cov[n_lever:, :n_lever].T
    return cov


# --------------------------------------------------------------------------- held-out comparison
