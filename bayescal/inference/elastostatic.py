"""Elastostatic identification: joint compliances and the compensator's spring from a campaign.

Klimchik et al., section V.  From a campaign (marker positions before and
after loading) the linear model of eq 30 gives one equation per measured
coordinate; ``ElastostaticModel(...).fit(campaign)`` returns the closed-form
estimates (eqs 33-35), the posterior of ``k1, k3..k6, K_theta2^0, K_c, s0``
with the joint-2 stiffness ``K_theta2^0 + K_c a L eta(q2; s0)`` (eq 8), the
identifiability analysis, and the comparison of the linear and exact models.

Markers are located on the tool by their measured unloaded positions, so a
campaign needs no description of the tool.  The *exact* model (the default)
replaces the linearisation of eq 30 by the static equilibrium of the virtual
joint model with gravity and the compensator: the difference between the
exact and the linear prediction at the current estimate is subtracted from
the measured deflections and the linear problem is solved again, until the
estimate no longer moves.  The posterior is then the linear-Gaussian posterior
of the corrected deflections; since the correction is a fraction of a percent
of the deflection and varies with the parameters by a fraction of that, its
dependence on the parameters within the posterior is neglected.

After sampling, every reported parameter is also judged by what the data did
determine (:func:`~bayescal.inference.identifiability.practical_reasons`): one whose
posterior is essentially its prior (for ``K_c``, an interval that reaches zero)
is reported as not identifiable from these data, with the reason in numbers,
while its posterior stays in the DataTree.
"""

from __future__ import annotations

import math
from typing import NamedTuple
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
import pinocchio as pin

from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.robot.compensator import Compensator, CompensatorGeometry
from bayescal.errors import InputError, NotIdentifiableWarning
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.inference.identifiability import Identifiability, analyse, grouped, practical_reasons
from bayescal.inference.likelihood import CompensatedPosterior, DeflectionEquations, GeometryPrior, PerAnglePosterior, compensator_regressor
from bayescal.sampling.summary import diagnostics, warn_if_unconverged
from bayescal.robot.kinematics import Robot
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.robot.stiffness import compliance_design, equilibrium
from bayescal.cell.tracker import TrackerNoise
from bayescal.units import DEG, MM, N_PER_MM, URAD_PER_NM

__all__ = [
    "ElastostaticModel",
    "ElastostaticResults",
    "ElastostaticDraws",
    "ClosedForm",
    "deflection_equations",
    "closed_form",
    "config_geometry",
    "posterior_geometry",
    "exact_deflections",
    "scale_masses",
    "MAX_DEFLECTION",
    "MAX_MARKER_DISTANCE",
    "MARKER_TOLERANCE",
    "PARAMETER_UNITS",
]

MAX_DEFLECTION = 50 * MM
"""Largest marker deflection accepted: far beyond what a loaded industrial robot shows."""
MAX_MARKER_DISTANCE = 2.0
"""Largest distance (m) of a marker from the flange origin: a tool is smaller than this."""
MARKER_TOLERANCE = 10 * MM
"""How far a marker's position on the tool may scatter between rows (gravity sag and
the exact model's correction move it by a few mm at most)."""
ANGLE_DECIMALS = 3
"""q2 angles equal when rounded to this many decimals of a degree are one angle of eq 34."""

PARAMETER_UNITS = {
    "k1": "urad/(N m)",
    "k2": "urad/(N m)",
    "k3": "urad/(N m)",
    "k4": "urad/(N m)",
    "k5": "urad/(N m)",
    "k6": "urad/(N m)",
    "K_c": "N/mm",
    "s0": "mm",
}
"""The reported parameters and their units (k2 is ``1/K_theta2^0``, joint 2 without its compensator)."""



# --------------------------------------------------------------------------- equations


def deflection_equations(
    robot: Robot, campaign: Campaign, *, noise: str = "axis", tracker: TrackerNoise | None = None
) -> tuple[DeflectionEquations, np.ndarray, np.ndarray]:
    """The scalar equations of eq 30 for a campaign, with the loads' joint torques.

    Parameters
    ----------
    robot
        The robot.
    campaign
        The measurements.
    noise
        ``"axis"``: one noise level per base-frame axis; ``"marker"``: one per marker.
    tracker
        When given, each equation's noise is taken proportional to the tracker's
        error at the unloaded and loaded positions, ``sqrt(s(p0)^2 + s(p1)^2)``
        (scaled to mean 1; the unknown level per group multiplies it).

    Returns
    -------
    equations : DeflectionEquations
        Three equations per campaign row (x, y, z of the deflection).
    torque : numpy.ndarray
        ``(N, 6)`` joint torques ``J_F' w`` of each row's load (N·m).
    points : numpy.ndarray
        ``(N, 3)`` markers in the flange frame (m), from the unloaded positions.
    """
    n = len(campaign)
    design = np.empty((n, 3, 6))
    torque = np.empty((n, 6))
    points = np.empty((n, 3))
    for i in range(n):
        points[i] = robot.point_in_flange(campaign.q[i], campaign.p0[i])
        design[i] = compliance_design(robot, campaign.q[i], points[i], campaign.wrench[i])
        torque[i] = robot.flange_jacobian(campaign.q[i]).T @ campaign.wrench[i]
    q2_deg = np.round(campaign.q[:, COMPENSATED_JOINT] / DEG, ANGLE_DECIMALS)
    values, angle = np.unique(q2_deg, return_inverse=True)
    if noise == "axis":
        group, names = np.tile(np.arange(3), n), ("x", "y", "z")
    elif noise == "marker":
        names_, index = np.unique(campaign.marker.astype(str), return_inverse=True)
        group, names = np.repeat(index, 3), tuple(str(m) for m in names_)
    else:
        raise ValueError(f"noise must be 'axis' or 'marker', got {noise!r}")
    equations = DeflectionEquations(
        y=campaign.displacement.reshape(-1),
        design=design.reshape(-1, 6),
        angle=np.repeat(angle, 3),
        q2=values * DEG,
        group=group,
        group_names=names,
        scale=None if tracker is None else np.repeat(_relative_noise(tracker, campaign), 3),
    )
    return equations, torque, points


def _deflection_noise(tracker: TrackerNoise, campaign: Campaign) -> np.ndarray:
    """Nominal sd (m) of each coordinate of each row's deflection: the tracker reads p0 and p1 independently."""
    return np.hypot(tracker.sigma(campaign.p0), tracker.sigma(campaign.p1))


def _relative_noise(tracker: TrackerNoise, campaign: Campaign) -> np.ndarray:
    sd = _deflection_noise(tracker, campaign)
    return sd / sd.mean()


def check_campaign(robot: Robot, campaign: Campaign, points: np.ndarray) -> None:
    """Reject deflections or marker positions no robot could produce; warn when all loads are parallel.

    Raises
    ------
    InputError
        A deflection above :data:`MAX_DEFLECTION` or a marker farther than
        :data:`MAX_MARKER_DISTANCE` from the flange (positions in the wrong unit).
    """
    deflection = np.linalg.norm(campaign.displacement, axis=1)
    worst = int(np.argmax(deflection))
    if deflection[worst] > MAX_DEFLECTION:
        raise InputError(
            f"marker '{campaign.marker[worst]}' deflects by {deflection[worst] / MM:.4g} mm under load, more than the "
            f"{MAX_DEFLECTION / MM:.0f} mm a loaded robot can plausibly deflect: are x1_mm..z1_mm in another unit?",
            source=campaign.source,
            line=int(campaign.lines[worst]) or None,
            column="xyz"[int(np.argmax(np.abs(campaign.displacement[worst])))] + "1_mm",
        )
    distance = np.linalg.norm(points, axis=1)
    worst = int(np.argmax(distance))
    if distance[worst] > MAX_MARKER_DISTANCE:
        raise InputError(
            f"marker '{campaign.marker[worst]}' is {distance[worst]:.3g} m from the flange, farther than any tool "
            f"({MAX_MARKER_DISTANCE:g} m): are x0_mm..z0_mm in metres instead of mm?",
            source=campaign.source,
            line=int(campaign.lines[worst]) or None,
            column="xyz"[int(np.argmax(np.abs(campaign.p0[worst])))] + "0_mm",
        )
    _check_markers(campaign, points)
    forces = campaign.wrench[:, :3]
    loaded = forces[np.linalg.norm(forces, axis=1) > 0]
    if loaded.shape[0]:
        singular = np.linalg.svd(loaded / np.linalg.norm(loaded, axis=1, keepdims=True), compute_uv=False)
        if singular.size < 2 or singular[1] < 1e-3 * singular[0]:
            direction = loaded[0] / np.linalg.norm(loaded[0])
            warnings.warn(
                f"{campaign.source}: all loads are parallel (force direction {np.array2string(direction, precision=3)}); "
                "Klimchik et al. advise varying the load direction: parameters such loads cannot excite are reported as not identifiable",
                UserWarning,
                stacklevel=2,
            )


def _check_markers(campaign: Campaign, points: np.ndarray) -> None:
    """Each marker label must name one point of the tool, measured in several configurations.

    A marker is rigid on the tool, so its flange-frame position, recovered from
    each row's unloaded reading, is the same in every row up to the arm's sag.
    A label seen in a single configuration, or a row far from where its label
    sits in the other rows, is a typo or a swapped label, which would silently
    bias the compliances.
    """
    labels = sorted(set(campaign.marker))
    configurations = {label: np.unique(campaign.config[campaign.marker == label]) for label in labels}
    repeated = [label for label in labels if configurations[label].size >= 2]
    for label in labels:
        rows = np.flatnonzero(campaign.marker == label)
        # A label seen once is only suspicious beside labels that are measured in several configurations.
        if configurations[label].size < 2 and repeated:
            raise InputError(
                f"unknown marker '{label}': it is measured in configuration {configurations[label][0]} only, while "
                f"{', '.join(repeated)} are measured in several; a marker must be measured in at least two configurations",
                source=campaign.source,
                line=int(campaign.lines[rows[0]]) or None,
                column="marker",
            )
        centre = np.median(points[rows], axis=0)
        offset = np.linalg.norm(points[rows] - centre, axis=1)
        worst = int(np.argmax(offset))
        if offset[worst] > MARKER_TOLERANCE:
            raise InputError(
                f"marker '{label}' is {offset[worst] / MM:.1f} mm from where '{label}' sits on the tool in its other "
                f"rows (more than {MARKER_TOLERANCE / MM:.0f} mm): a mislabelled marker?",
                source=campaign.source,
                line=int(campaign.lines[rows[worst]]) or None,
                column="marker",
            )


# --------------------------------------------------------------------------- closed form


@dataclass(frozen=True)
class ClosedForm:
    """Least-squares estimates of eqs 33-35 (SI).

    Attributes
    ----------
    per_angle : numpy.ndarray
        Compliances of the identifiable per-angle columns (eq 33).
    cov : numpy.ndarray
        Their covariance ``sigma^2 (X'X)^-1`` (eq 37) with the pooled residual variance.
    sigma : numpy.ndarray
        Residual standard deviation per noise group (m).
    compliances : numpy.ndarray
        ``(6,)`` joint compliances with ``k2 = 1/K_theta2^0``; ``nan`` where not identifiable.
    spring : numpy.ndarray | None
        ``[K_theta2^0, K_c, s0]`` from eq 34 (None when not identifiable).
    k2 : numpy.ndarray
        Equivalent joint-2 compliance at each q2 angle (``nan`` where not identifiable).
    k2_sd : numpy.ndarray
        Its standard deviation from ``cov``.
    """

    per_angle: np.ndarray
    cov: np.ndarray
    sigma: np.ndarray
    compliances: np.ndarray
    spring: np.ndarray | None
    k2: np.ndarray
    k2_sd: np.ndarray


def closed_form(
    equations: DeflectionEquations,
    identifiability: Identifiability,
    geometry: np.ndarray,
) -> ClosedForm:
    """Eq 33 on the identifiable per-angle columns, then eq 34 for the compensator (unweighted, as the paper)."""
    X = equations.per_angle_design()[:, identifiability.identifiable]
    k, *_ = np.linalg.lstsq(X, equations.y, rcond=None)
    residual = equations.y - X @ k
    dof = max(equations.n - X.shape[1], 1)
    cov = residual @ residual / dof * np.linalg.inv(X.T @ X)
    groups = len(equations.group_names)
    ssr = np.bincount(equations.group, weights=residual**2, minlength=groups)
    counts = np.bincount(equations.group, minlength=groups)
    sigma = np.sqrt(ssr / np.maximum(counts * dof / equations.n, 1.0))
    columns = [c for c, keep in zip(equations.per_angle_columns(), identifiability.identifiable) if keep]
    compliances = np.full(6, np.nan)
    k2 = np.full(equations.q2.size, np.nan)
    k2_sd = np.full(equations.q2.size, np.nan)
    for index, (value, (joint, angle)) in enumerate(zip(k, columns)):
        if angle is None:
            compliances[joint] = value
        else:
            k2[angle] = value
            k2_sd[angle] = np.sqrt(cov[index, index])
    spring = None
    if identifiability.compensator:
        known = np.isfinite(k2) & (k2 > 0)
        C = CompensatorGeometry(*geometry).regressor(equations.q2[known])
        w = np.linalg.lstsq(C, 1.0 / k2[known], rcond=None)[0]
        spring = np.array([w[0], w[1], w[2] / w[1] if w[1] != 0 else np.nan])
        compliances[COMPENSATED_JOINT] = 1.0 / w[0]
    return ClosedForm(per_angle=k, cov=cov, sigma=sigma, compliances=compliances, spring=spring, k2=k2, k2_sd=k2_sd)


# --------------------------------------------------------------------------- exact model


def exact_deflections(
    robot: Robot,
    q: np.ndarray,
    wrench: np.ndarray,
    compliances: np.ndarray,
    compensator: Compensator | None,
    *,
    points_in_flange: np.ndarray | None = None,
    unloaded_positions: np.ndarray | None = None,
    load_point: np.ndarray | None = None,
) -> np.ndarray:
    """Deflections (m) of tool points between the unloaded and the loaded static equilibria.

    Both equilibria include the links' weight and the compensator; the loaded
    one adds ``wrench``.  The points are given either in the flange frame or by
    their measured unloaded positions in the base frame (then located on the
    tool at the unloaded equilibrium).

    Parameters
    ----------
    robot
        The robot.
    q
        ``(6,)`` commanded joint angles (rad).
    wrench
        ``(6,)`` load at the flange origin in base axes (N, N·m), as applied at ``q``.
    compliances
        ``(6,)`` joint compliances (rad/(N·m)), ``compliances[1] = 1/K_theta2^0``.
    compensator
        The spring compensator of joint 2.
    points_in_flange, unloaded_positions
        ``(k, 3)`` points, one of the two (m).
    load_point
        Flange-frame point where the load's force acts (a hanging mass); None: flange origin, dead load.
    """
    zero = np.zeros(6)
    unloaded = q + equilibrium(robot, q, compliances, zero, compensator=compensator, load_point=load_point)
    loaded = q + equilibrium(robot, q, compliances, wrench, compensator=compensator, load_point=load_point)
    if points_in_flange is None:
        points_in_flange = robot.point_in_flange(unloaded, unloaded_positions)
    return robot.point_position(loaded, points_in_flange) - robot.point_position(unloaded, points_in_flange)


def scale_masses(robot: Robot, factor: float) -> Robot:
    """A copy of ``robot`` with every link's mass and rotational inertia multiplied by ``factor``."""
    model = robot.model.copy()
    for i in range(1, model.njoints):
        inertia = model.inertias[i]
        model.inertias[i] = pin.Inertia(inertia.mass * factor, inertia.lever, inertia.inertia * factor)
    return Robot(model, flange=robot.flange, source=robot.source)


# --------------------------------------------------------------------------- model and results

TABLE_II_SD = np.array([0.06, 0.70, 0.69]) / 3 * MM
"""Standard deviations of L, a_x, a_y: Klimchik et al., Table II's ±3σ half-widths divided by 3."""
PHI_SD = 0.05 * DEG
"""Standard deviation of the lever angle phi when no geometry posterior is given: an ESTIMATE
(Table II gives none); the arc fits of the geometry step determine phi to a few hundredths of a degree."""


def posterior_geometry(path) -> GeometryPrior:
    """Geometry prior from a saved geometry posterior (NetCDF with L, a_x, a_y in mm and phi in deg).

    The Gaussian with the draws' mean and covariance: the elastostatic data then
    barely move it, and the same prior serves the Gibbs and the emcee paths.
    """
    from bayescal.sampling.summary import load

    try:
        tree = load(path)
        posterior = tree["posterior"]
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"cannot read a geometry posterior ({type(exc).__name__})", source=str(path)) from None
    columns = []
    for name, factor in (("L", MM), ("a_x", MM), ("a_y", MM), ("phi", DEG)):
        if name not in posterior:
            tree.close()
            raise InputError(f"the geometry posterior has no variable '{name}'", source=str(path), column=name)
        columns.append(np.asarray(posterior[name].values, dtype=float).reshape(-1) * factor)
    tree.close()
    draws = np.column_stack(columns)
    spread = draws.std(axis=0)
    if np.any(spread <= 1e-9 * np.abs(draws.mean(axis=0))) or np.linalg.matrix_rank(np.corrcoef(draws, rowvar=False)) < 4:
        raise InputError(
            "the geometry posterior's draws of L, a_x, a_y, phi have a singular covariance (a constant or duplicated variable)",
            source=str(path),
        )
    return GeometryPrior.from_draws(draws, source=f"geometry posterior {path}")


def config_geometry(compensator: CompensatorGeometry, source: str = "") -> GeometryPrior:
    """Gaussian geometry prior centred on a config's compensator with Table II's uncertainties (and :data:`PHI_SD`)."""
    mean = np.array([compensator.L, compensator.a_x, compensator.a_y, compensator.phi])
    sd = np.concatenate([TABLE_II_SD, [PHI_SD]])
    return GeometryPrior(mean=mean, cov=np.diag(sd**2), source=f"{source} with Klimchik et al. Table II ±3σ/3".strip())


class _Prepared(NamedTuple):
    """A campaign made ready for sampling: its equations, what they identify and the closed forms."""

    equations: DeflectionEquations
    identifiability: Identifiability
    linear_closed_form: ClosedForm
    offset: np.ndarray
    """Exact minus linear prediction of every equation (m); zeros for the linear model."""
    closed_form: ClosedForm
    iterations: int


@dataclass
class ElastostaticModel:
    """Identification of the joint compliances and the compensator spring.

    Parameters
    ----------
    robot
        The robot (its URDF gives kinematics and, for the exact model, link masses).
    geometry
        Prior of the compensator geometry ``[L, a_x, a_y, phi]`` (m, rad): from a
        geometry posterior (:meth:`GeometryPrior.from_draws`) or from the config.
    nominal_compliances
        ``(6,)`` compliances (rad/(N·m), k2 without compensator) used only by the
        exact model for parameters the campaign cannot identify.
    nominal_spring
        ``(K_c, s0)`` (N/m, m) used by the exact model when the compensator is not identifiable.
    model
        ``"exact"`` (default) or ``"linear"`` (eq 30 as is).
    sampler
        ``"gibbs"`` (default), ``"emcee"``, or an object with ``sample(log_prob, start, scale, rng)``.
    noise
        ``"axis"`` (one unknown noise level per base axis) or ``"marker"``.
    load_point
        Flange-frame point (m) where the load's force acts in the exact model.
    tracker
        The tracker's noise model: weights the equations by its distance-dependent
        error and gives the chi-square of the fit against the nominal noise.
        None: equal weights, no chi-square.
    n_chains, n_tune, n_draws
        Sampler sizes.
    compare_linear
        With the exact model, also fit the linear one and tabulate the difference.
    """

    robot: Robot
    geometry: GeometryPrior
    nominal_compliances: np.ndarray
    nominal_spring: tuple[float, float]
    model: str = "exact"
    sampler: object = "gibbs"
    noise: str = "axis"
    load_point: np.ndarray | None = None
    tracker: TrackerNoise | None = None
    n_chains: int = 4
    n_tune: int = 500
    n_draws: int = 1500
    compare_linear: bool = True
    max_iterations: int = 10

    @classmethod
    def from_cell(cls, cell: Cell, geometry: GeometryPrior | None = None, **options) -> ElastostaticModel:
        """A model for a calibration cell: its robot, tool load point, tracker, and nominal stiffness.

        ``geometry`` defaults to :func:`config_geometry` of the cell's compensator;
        ``options`` are the other fields (``model``, ``sampler``, ``n_draws`` …).
        """
        if cell.compensator is None:
            raise InputError("the cell has no [compensator]: the elastostatic model needs its geometry", source=cell.source)
        spring = (cell.compensator.K_c, cell.compensator.s0)
        return cls(
            robot=cell.robot,
            geometry=geometry if geometry is not None else config_geometry(cell.compensator, cell.source),
            nominal_compliances=np.asarray(cell.compliances, dtype=float),
            nominal_spring=spring,
            load_point=cell.load_point,
            tracker=cell.tracker,
            **options,
        )

    def estimate(self, campaign: Campaign) -> tuple[ClosedForm, Identifiability]:
        """Closed-form estimates (eqs 33-34, after the exact model's correction) without sampling."""
        prepared = self._prepare(campaign, announce=False)
        return prepared.closed_form, prepared.identifiability

    def _prepare(self, campaign: Campaign, *, announce: bool = True) -> _Prepared:
        if self.model not in ("exact", "linear"):
            raise ValueError(f"model must be 'exact' or 'linear', got {self.model!r}")
        equations, torque, points = deflection_equations(self.robot, campaign, noise=self.noise, tracker=self.tracker)
        check_campaign(self.robot, campaign, points)
        configs = np.unique(campaign.config, return_index=True)[1]
        ident = analyse(
            equations.whitened().per_angle_design(),
            equations.per_angle_columns(),
            equations.q2,
            torque[configs],
            equations.angle[3 * configs],
        )
        if ident.compensator:
            ident = _check_regression(ident, equations.per_angle_columns(), equations.q2, self.geometry.mean)
        if announce:
            for names, reason in grouped({k: v for k, v in ident.reasons.items() if not k.startswith("k2_q2[")}):
                warnings.warn(f"{_listed(names)} not identifiable: {reason}", NotIdentifiableWarning, stacklevel=3)
            if ident.ill_conditioned:
                warnings.warn(
                    f"the campaign is ill-conditioned (condition number {ident.condition_number:.3g} of the unit-column "
                    "design): the intervals are wide and sensitive to the noise model",
                    UserWarning,
                    stacklevel=3,
                )
        linear_cf = closed_form(equations.whitened(), ident, self.geometry.mean)
        offset = np.zeros(equations.n)
        iterations = 0
        cf = linear_cf
        if self.model == "exact":
            cf, offset, iterations = self._relinearise(campaign, equations, ident, linear_cf)
        return _Prepared(equations, ident, linear_cf, offset, cf, iterations)

    def fit(self, campaign: Campaign, rng: np.random.Generator | int = 0) -> ElastostaticResults:
        """Identify the parameters from ``campaign``; ``rng`` seeds every random draw."""
        rng = np.random.default_rng(rng)
        equations, ident, linear_cf, offset, cf, iterations = self._prepare(campaign)
        corrected = replace(equations, y=equations.y - offset)
        tree, draws = self._sample(corrected.whitened(), ident, cf, rng)

        linear_tree = None
        if self.model == "exact" and self.compare_linear:
            linear_tree, _ = self._sample(equations.whitened(), ident, linear_cf, rng)

        practical = self._practical(tree, equations, ident, cf)
        for names, reason in grouped(practical):
            warnings.warn(f"{_listed(names)} not identifiable from these data: {reason}", NotIdentifiableWarning, stacklevel=2)
        residual = corrected.y - corrected.per_angle_design()[:, ident.identifiable] @ cf.per_angle
        warn_if_unconverged(diagnostics(tree), what="the elastostatic posterior")
        return ElastostaticResults(
            tree=tree,
            identifiability=replace(ident, practical=practical),
            closed_form=cf,
            model=self.model,
            q2=equations.q2,
            draws=draws,
            geometry=self.geometry,
            n_equations=equations.n,
            n_rows=len(campaign),
            residual_rms=float(np.sqrt(np.mean(residual**2))),
            chi2_per_dof=self._chi2_per_dof(campaign, residual, cf.per_angle.size),
            nonlinearity=float(np.abs(offset).max(initial=0.0)),
            iterations=iterations,
            linear_tree=linear_tree,
            sampler_name=self.sampler if isinstance(self.sampler, str) else type(self.sampler).__name__,
        )

    def chi2_per_dof(self, campaign: Campaign) -> float | None:
        """Chi-square per degree of freedom of the closed-form fit against the tracker's nominal noise.

        The fit is this model's (with the exact model, after its relinearisation).
        The sum runs over the campaign's scalar deflection equations (3 per row),
        each with the variance of two independent tracker readings; the degrees of
        freedom are the equations less the per-angle compliances fitted.  None
        without a tracker noise model.
        """
        equations, ident, _, offset, cf, _ = self._prepare(campaign, announce=False)
        corrected = replace(equations, y=equations.y - offset)
        residual = corrected.y - corrected.per_angle_design()[:, ident.identifiable] @ cf.per_angle
        return self._chi2_per_dof(campaign, residual, cf.per_angle.size)

    def _chi2_per_dof(self, campaign: Campaign, residual: np.ndarray, n_free: int) -> float | None:
        if self.tracker is None:
            return None
        normalised = residual / np.repeat(_deflection_noise(self.tracker, campaign), 3)
        return float(normalised @ normalised / (residual.size - n_free))

    def _practical(self, tree, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm) -> dict[str, str]:
        """Practical identifiability of the sampled parameters (:func:`~bayescal.inference.identifiability.practical_reasons`)."""
        from bayescal.sampling.summary import summarize

        summary = summarize(tree)
        L, a_x, a_y = self.geometry.mean[:3]
        # s0's prior is flat on (0, a + L): its sd is the width over sqrt(12).
        prior_sd: dict[str, float | None] = {name: None for name in PARAMETER_UNITS if name != "s0"}
        prior_sd["s0"] = (math.hypot(a_x, a_y) + L) / math.sqrt(12.0) / MM
        prior_sd |= {name: None for name in summary.index if name.startswith("k2_q2[")}
        context = {}
        if "K_c" in summary.index:
            context["K_c"] = self._compensator_context(equations, ident, cf, summary.loc["k2", "mean"] * URAD_PER_NM)
        return practical_reasons(summary, prior_sd, requires={"s0": "K_c"}, context=context)

    def _compensator_context(self, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm, k2: float) -> str:
        """How much the compensator changes the joint-2 stiffness, against how finely the per-angle compliances are known."""
        Kc, s0 = self.nominal_spring
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(Kc, s0)
        share = 100.0 * np.abs(compensator.stiffness(equations.q2)) * k2
        columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
        sd = np.sqrt(np.diag(cf.cov))
        resolution = [300.0 * sd[i] / cf.per_angle[i] for i, (joint, _) in enumerate(columns) if joint == COMPENSATED_JOINT]
        return (
            f"the compensator changes the joint-2 stiffness by {share.min():.2f}–{share.max():.2f} % across the "
            f"campaign's {equations.q2.size} q2 angles (at the config's K_c = {Kc / N_PER_MM:.4g} N/mm, "
            f"s0 = {s0 / MM:.4g} mm), while the per-angle joint-2 compliances are resolved to "
            f"±{np.median(resolution):.2f} % (3σ, median over the angles)"
        )

    # ----------------------------------------------------------------- exact model
    def _offset(self, campaign: Campaign, equations: DeflectionEquations, cf: ClosedForm) -> np.ndarray:
        """Exact minus linear prediction of every equation at the closed-form estimate ``cf``.

        The per-angle joint-2 compliances of ``cf`` fix joint 2's stiffness at each
        angle; the compensator's static torque, which balances the arm's weight and
        so sets the unloaded sag, is the nominal spring's: the deflections
        determine K_c far too loosely for that.
        """
        compliances = np.where(np.isfinite(cf.compliances) & (cf.compliances > 0), cf.compliances, self.nominal_compliances)
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(*self.nominal_spring)
        nominal_k2 = 1.0 / compensator.joint_stiffness(equations.q2, 1.0 / self.nominal_compliances[COMPENSATED_JOINT])
        k2 = np.where(np.isfinite(cf.k2) & (cf.k2 > 0), cf.k2, nominal_k2)
        exact = np.empty((len(campaign), 3))
        row_angle = equations.angle[::3]
        for config in np.unique(campaign.config):
            rows = np.flatnonzero(campaign.config == config)
            k = compliances.copy()
            # The joint's own stiffness that, with the compensator, gives this angle's equivalent compliance.
            k[COMPENSATED_JOINT] = 1.0 / (1.0 / k2[row_angle[rows[0]]] - compensator.stiffness(campaign.q[rows[0], COMPENSATED_JOINT]))
            exact[rows] = exact_deflections(
                self.robot,
                campaign.q[rows[0]],
                campaign.wrench[rows[0]],
                k,
                compensator,
                unloaded_positions=campaign.p0[rows],
                load_point=self.load_point,
            )
        per_row = np.repeat(compliances[None, :], equations.n, axis=0)
        per_row[:, COMPENSATED_JOINT] = k2[equations.angle]
        linear = np.einsum("ij,ij->i", equations.design, per_row)
        return exact.reshape(-1) - linear

    def _relinearise(self, campaign, equations, ident, cf):
        sd = np.sqrt(np.diag(cf.cov))
        offset = np.zeros(equations.n)
        for iteration in range(1, self.max_iterations + 1):
            offset = self._offset(campaign, equations, cf)
            updated = closed_form(replace(equations, y=equations.y - offset).whitened(), ident, self.geometry.mean)
            change = np.abs(updated.per_angle - cf.per_angle)
            moved = float(np.max(change / sd))
            cf = updated
            if moved < 1e-3 or np.all(change <= 1e-9 * np.abs(cf.per_angle)):
                return cf, offset, iteration
        warnings.warn(
            f"the exact model did not settle in {self.max_iterations} relinearisations (last move {moved:.2g} sd)",
            UserWarning,
            stacklevel=3,
        )
        return cf, offset, self.max_iterations

    # ----------------------------------------------------------------- sampling
    def _sampler(self):
        if self.sampler == "gibbs":
            return GibbsSampler(n_chains=self.n_chains, n_tune=self.n_tune, n_draws=self.n_draws)
        if self.sampler == "emcee":
            return EnsembleSampler(n_chains=self.n_chains, n_tune=max(self.n_tune, 1000), n_draws=self.n_draws // 4 or 1)
        if isinstance(self.sampler, str):
            raise ValueError(f"sampler must be 'gibbs', 'emcee' or a sampler object, got {self.sampler!r}")
        return self.sampler

    def _nominal_start(self, cf: ClosedForm, q2: np.ndarray) -> np.ndarray:
        """``[K_theta2^0, K_c, s0]`` with the nominal spring and the K_theta2^0 that best fits the per-angle k2."""
        Kc, s0 = self.nominal_spring
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(Kc, s0)
        known = np.isfinite(cf.k2) & (cf.k2 > 0)
        K0 = float(np.mean(1.0 / cf.k2[known] - compensator.stiffness(q2[known])))
        return np.array([K0, Kc, s0])

    def _sample(self, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm, rng):
        sampler = self._sampler()
        sd = np.sqrt(np.diag(cf.cov))
        log_sigma_scale = np.full(cf.sigma.size, 0.05)
        if ident.compensator:
            joints = tuple(j for j in range(6) if j != COMPENSATED_JOINT and f"k{j + 1}" not in ident.reasons)
            posterior = CompensatedPosterior(equations, joints, self.geometry)
            spring = cf.spring
            start = posterior.start(cf.compliances[list(joints)], spring, cf.sigma)
            if not np.isfinite(posterior.log_prob(start)):
                # Eq 34 can return a negative K_c or s0 when the data determine the spring
                # loosely; the chains then start from the nominal spring instead.
                spring = self._nominal_start(cf, equations.q2)
                start = posterior.start(cf.compliances[list(joints)], spring, cf.sigma)
            if not np.isfinite(posterior.log_prob(start)):
                raise InputError(
                    "neither the closed-form compensator estimate (eq 34) nor the nominal spring fits the campaign "
                    "with a positive joint-2 stiffness: the campaign does not determine the compensator"
                )
            if isinstance(sampler, GibbsSampler):
                raw = sampler.sample_compensated(posterior, start, rng)
            else:
                columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
                k_sd = np.array([sd[columns.index((j, None))] for j in joints])
                geometry_sd = np.sqrt(np.diag(self.geometry.cov)) if posterior.n_geometry else np.empty(0)
                scale = np.concatenate([k_sd, np.abs(spring) * [0.005, 0.05, 0.02], geometry_sd, log_sigma_scale])
                raw = sampler.sample(posterior.log_prob, start, scale, rng)
            draws = _compensated_draws(posterior, raw)
        else:
            posterior = PerAnglePosterior(equations, ident.identifiable)
            start = np.concatenate([cf.per_angle, np.log(cf.sigma)])
            if isinstance(sampler, GibbsSampler):
                raw = sampler.sample_per_angle(posterior, rng)
            else:
                raw = sampler.sample(posterior.log_prob, start, np.concatenate([sd, log_sigma_scale]), rng)
            draws = _per_angle_draws(posterior, raw)
        return _tree(draws, equations), draws


def _listed(names: list[str]) -> str:
    """``"k1 is"`` or ``"k2, K_c, s0 are"``."""
    return f"{', '.join(names)} {'is' if len(names) == 1 else 'are'}"


def _check_regression(
    ident: Identifiability, columns: list[tuple[int, int | None]], q2: np.ndarray, geometry: np.ndarray
) -> Identifiability:
    """Demote the compensator when the eq 34 regressor of the identified angles is rank deficient."""
    angles = sorted({a for (_, a), keep in zip(columns, ident.identifiable) if keep and a is not None})
    C = CompensatorGeometry(*geometry).regressor(q2[angles])
    C = C / np.linalg.norm(C, axis=0)
    singular = np.linalg.svd(C, compute_uv=False)
    if singular[-1] > 1e-8 * singular[0]:
        return ident
    reason = "the eq 34 regressor of the campaign's q2 angles is rank deficient: K_c and s0*K_c cannot be separated"
    reasons = dict(ident.reasons) | {name: reason for name in ("k2", "K_c", "s0")}
    return replace(ident, reasons=reasons, compensator=False)


# --------------------------------------------------------------------------- draws → DataTree


@dataclass(frozen=True)
class ElastostaticDraws:
    """Posterior draws in SI, each of shape ``(chain, draw[, ...])``.

    Attributes
    ----------
    compliances : dict
        ``{"k1": ..., "k2": ..., ...}`` joint compliances (rad/(N·m)) of the sampled joints;
        ``k2`` is ``1/K_theta2^0`` (joint 2 without its compensator) in the compensated model.
    spring : numpy.ndarray or None
        ``(chain, draw, 3)``: ``K_theta2^0`` (N·m/rad), ``K_c`` (N/m), ``s0`` (m); None in the per-angle model.
    k2 : numpy.ndarray
        ``(chain, draw, m)`` equivalent joint-2 compliance (rad/(N·m)) at each campaign angle.
    sigma : numpy.ndarray
        ``(chain, draw, groups)`` noise sd per group (m).
    geometry : numpy.ndarray or None
        ``(chain, draw, 4)``: ``L, a_x, a_y`` (m), ``phi`` (rad) when the geometry was sampled.
    """

    compliances: dict[str, np.ndarray]
    spring: np.ndarray | None
    k2: np.ndarray
    sigma: np.ndarray
    geometry: np.ndarray | None


def _compensated_draws(posterior: CompensatedPosterior, raw: np.ndarray) -> ElastostaticDraws:
    p = posterior.n_linear
    spring = raw[..., p : p + 3]
    geometry = raw[..., p + 3 : p + 3 + posterior.n_geometry] if posterior.n_geometry else None
    flat_spring = spring.reshape(-1, 3)
    flat_geometry = geometry.reshape(-1, 4) if geometry is not None else np.broadcast_to(posterior.geometry.mean, (flat_spring.shape[0], 4))
    k2 = np.array([posterior.joint2_compliance(s, g) for s, g in zip(flat_spring, flat_geometry)]).reshape(*raw.shape[:2], -1)
    compliances = {f"k{j + 1}": raw[..., i] for i, j in enumerate(posterior.joints)}
    compliances["k2"] = 1.0 / spring[..., 0]
    return ElastostaticDraws(
        compliances=compliances,
        spring=spring,
        k2=k2,
        sigma=np.exp(raw[..., p + 3 + posterior.n_geometry :]),
        geometry=geometry,
    )


def _per_angle_draws(posterior: PerAnglePosterior, raw: np.ndarray) -> ElastostaticDraws:
    columns = [c for c, keep in zip(posterior.equations.per_angle_columns(), posterior.free) if keep]
    compliances: dict[str, np.ndarray] = {}
    k2 = np.full((*raw.shape[:2], posterior.equations.q2.size), np.nan)
    for i, (joint, angle) in enumerate(columns):
        if angle is None:
            compliances[f"k{joint + 1}"] = raw[..., i]
        else:
            k2[..., angle] = raw[..., i]
    return ElastostaticDraws(compliances=compliances, spring=None, k2=k2, sigma=np.exp(raw[..., posterior.n_linear :]), geometry=None)


def _tree(draws: ElastostaticDraws, equations: DeflectionEquations):
    from bayescal.sampling.summary import posterior_tree

    values: dict[str, np.ndarray] = {name: value / URAD_PER_NM for name, value in sorted(draws.compliances.items())}
    units = {name: PARAMETER_UNITS[name] for name in values}
    if draws.spring is not None:
        values["K_c"] = draws.spring[..., 1] / N_PER_MM
        values["s0"] = draws.spring[..., 2] / MM
        units |= {"K_c": "N/mm", "s0": "mm"}
    keep = ~np.all(np.isnan(draws.k2), axis=(0, 1))
    values["k2_q2"] = draws.k2[..., keep] / URAD_PER_NM
    values["sigma"] = draws.sigma / MM
    units |= {"k2_q2": "urad/(N m)", "sigma": "mm"}
    dims = {"k2_q2": ["q2_deg"], "sigma": ["noise_group"]}
    coords = {"q2_deg": [f"{v:.3f}" for v in equations.q2[keep] / DEG], "noise_group": list(equations.group_names)}
    if draws.geometry is not None:
        for i, (name, unit, factor) in enumerate((("L", "mm", MM), ("a_x", "mm", MM), ("a_y", "mm", MM), ("phi", "deg", DEG))):
            values[name] = draws.geometry[..., i] / factor
            units[name] = unit
    return posterior_tree(values, units=units, dims=dims, coords=coords)


@dataclass
class ElastostaticResults:
    """What :meth:`ElastostaticModel.fit` found.

    Attributes
    ----------
    tree : xarray.DataTree
        The posterior (edge units, see :data:`PARAMETER_UNITS`; ``k2_q2`` the
        equivalent joint-2 compliance at each campaign angle, ``sigma`` the noise
        per group in mm, and the geometry when it was sampled).
    identifiability : Identifiability
        Structural reasons, and the practical ones found after sampling.
    closed_form : ClosedForm
        Estimates of eqs 33-34 (after the exact model's correction when used).
    model : str
        ``"exact"`` or ``"linear"``.
    q2 : numpy.ndarray
        The campaign's distinct joint-2 angles (rad).
    n_equations, n_rows : int
        Scalar equations (3 per campaign row) and campaign rows.
    residual_rms : float
        RMS residual of the closed-form fit (m).
    chi2_per_dof : float | None
        Chi-square per degree of freedom against the nominal tracker noise.
    nonlinearity : float
        Largest difference between the exact and the linear model's prediction (m).
    iterations : int
        Relinearisations of the exact model.
    linear_tree : xarray.DataTree | None
        Posterior of the linear model, when compared.
    """

    tree: object
    identifiability: Identifiability
    closed_form: ClosedForm
    model: str
    q2: np.ndarray
    draws: ElastostaticDraws = field(repr=False)
    geometry: GeometryPrior = field(repr=False)
    n_equations: int = 0
    n_rows: int = 0
    residual_rms: float = math.nan
    chi2_per_dof: float | None = None
    nonlinearity: float = 0.0
    iterations: int = 0
    linear_tree: object | None = None
    sampler_name: str = "gibbs"

    def summary(self) -> pd.DataFrame:
        """Mean, sd, ±3σ interval, R-hat, ESS and unit of every posterior variable."""
        from bayescal.sampling.summary import summarize

        return summarize(self.tree)

    def parameters(self) -> dict[str, dict]:
        """The CLI's ``parameters`` block: k1..k6, K_c, s0, each an estimate or ``{"identifiable": false, "reason"}``.

        A parameter is given as an estimate only when it is identifiable both
        structurally and from these data (:attr:`Identifiability.not_identifiable`).
        """
        from bayescal.sampling.summary import parameters_json

        summary = self.summary()
        reasons = self.identifiability.not_identifiable
        known = parameters_json(summary.loc[[name for name in PARAMETER_UNITS if name in summary.index]])
        out: dict[str, dict] = {}
        for name in PARAMETER_UNITS:
            if name in known and name not in reasons:
                out[name] = known[name]
            else:
                out[name] = {"identifiable": False, "reason": reasons.get(name, "not sampled")}
        return out

    def weakly_determined(self) -> dict[str, dict]:
        """Posterior summary (mean, sd, lo3, hi3, unit) of the sampled parameters that are not identifiable from these data.

        They are kept for inspection, not as estimates: their intervals mostly
        reflect the prior.
        """
        from bayescal.sampling.summary import parameters_json

        summary = self.summary()
        names = [name for name in self.identifiability.practical if name in summary.index]
        return parameters_json(summary.loc[names])

    def diagnostics(self) -> dict:
        """Convergence and fit diagnostics (the CLI's ``diagnostics`` block)."""
        report = diagnostics(self.tree)
        report |= {
            "model": self.model,
            "sampler": self.sampler_name,
            "n_equations": self.n_equations,
            "residual_rms_mm": self.residual_rms / MM,
            "chi2_per_dof": self.chi2_per_dof,
            "nonlinearity_mm": self.nonlinearity / MM,
            "relinearisations": self.iterations,
        }
        return report

    def equivalent_compliance(self, q2: np.ndarray) -> np.ndarray:
        """``(S, n)`` posterior draws of joint 2's equivalent compliance (rad/(N·m)) at angles ``q2`` (rad).

        ``1 / (K_theta2^0 + K_c·a·L·η(q2))`` of eq 8 with every draw of the
        spring and, when it was propagated, of the compensator geometry: the
        paper's Fig. 7 with its uncertainty.  Needs the compensated model (at
        least three q2 angles).
        """
        d = self.draws
        if d.spring is None:
            raise ValueError("the campaign does not identify the compensator model (fewer than three q2 angles)")
        spring = d.spring.reshape(-1, 3)
        geometry = d.geometry.reshape(-1, 4) if d.geometry is not None else np.broadcast_to(self.geometry.mean, (spring.shape[0], 4))
        q2 = np.asarray(q2, dtype=float)
        return np.array([1.0 / (compensator_regressor(g, q2) @ [K0, Kc, s0 * Kc]) for (K0, Kc, s0), g in zip(spring, geometry)])

    def linear_vs_exact(self) -> pd.DataFrame | None:
        """Shift of each linear-model estimate in exact-model sd, and the ratio of their sds."""
        if self.linear_tree is None:
            return None
        from bayescal.sampling.summary import summarize

        exact = self.summary()
        linear = summarize(self.linear_tree)
        names = [n for n in exact.index if n in linear.index and not n.startswith("sigma")]
        return pd.DataFrame(
            {
                "exact_mean": exact.loc[names, "mean"],
                "linear_mean": linear.loc[names, "mean"],
                "shift_in_sd": (linear.loc[names, "mean"] - exact.loc[names, "mean"]) / exact.loc[names, "sd"],
                "sd_ratio": linear.loc[names, "sd"] / exact.loc[names, "sd"],
                "unit": exact.loc[names, "unit"],
            }
        )

    def compliance_draws(self, q2: float, fill: np.ndarray | None = None) -> np.ndarray | None:
        """``(S, 6)`` posterior draws of the compliances (rad/(N·m)) acting at joint angle ``q2``.

        Joint 2's entry is its equivalent compliance at ``q2`` (with the
        compensator).  A joint the campaign cannot identify takes its value from
        ``fill`` (no uncertainty), or makes the result ``None`` without it;
        ``None`` too when the compensator is not identified and ``q2`` is not a
        campaign angle.
        """
        d = self.draws
        missing = [j for j in range(6) if j != COMPENSATED_JOINT and f"k{j + 1}" not in d.compliances]
        if missing and fill is None:
            return None
        if d.spring is not None:
            k2 = self.equivalent_compliance(np.array([q2]))[:, 0]
        else:
            match = np.flatnonzero(np.abs(self.q2 - q2) < 0.5 * 10.0**-ANGLE_DECIMALS * DEG)
            if not match.size or np.all(np.isnan(d.k2[..., match[0]])):
                return None
            k2 = d.k2[..., match[0]].reshape(-1)
        columns = [
            k2 if j == COMPENSATED_JOINT else np.full(k2.size, fill[j]) if j in missing else d.compliances[f"k{j + 1}"].reshape(-1)
            for j in range(6)
        ]
        return np.column_stack(columns)
