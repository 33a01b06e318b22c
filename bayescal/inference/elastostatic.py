"""Elastostatic identification: joint compliances and the compensator law's parameters from a campaign.

Klimchik et al., section V.  ``ElastostaticModel(...).fit(campaign)`` builds
the campaign's equations (:mod:`~bayescal.inference.equations`), analyses what
they identify (:mod:`~bayescal.inference.identifiability`), solves the closed
forms of eqs 33-35 (:mod:`~bayescal.inference.closedform`), corrects the
deflections by the exact model (:mod:`~bayescal.inference.exact`), samples the
posterior of ``k1, k3..k6, K_theta2^0, K_c, s0`` with the joint-2 stiffness
``K_theta2^0 + K_c a L eta(q2; s0)`` of eq 8 (:mod:`~bayescal.inference.likelihood`)
with the sampler it was given (:mod:`~bayescal.inference.posterior`), checks the
fit against the tracker's noise and the repeats (:mod:`~bayescal.inference.fit_checks`),
and returns :class:`~bayescal.inference.results.ElastostaticResults`.

The *exact* model (the default) replaces the linearisation of eq 30 by the
static equilibrium of the virtual joint model with gravity and the
compensator: the difference between the exact and the linear prediction at
the current estimate is subtracted from the measured deflections and the
linear problem is solved again, until the estimate no longer moves
(:class:`~bayescal.inference.exact.ExactCorrection`).  The
posterior is then the linear-Gaussian posterior of the corrected deflections;
since the correction is a fraction of a percent of the deflection and varies
with the parameters by a fraction of that, its dependence on the parameters
within the posterior is neglected.

After sampling, every reported parameter is also judged by what the data did
determine (:func:`~bayescal.inference.identifiability.practical_reasons`): one whose
posterior is essentially its prior (for ``K_c``, an interval that reaches zero)
is reported as not identifiable from these data, with the reason in numbers,
while its posterior stays in the DataTree.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError, NotIdentifiableWarning
from bayescal.inference.closedform import ClosedForm, closed_form
from bayescal.inference.equations import HANGING_ONLY_REASON, DeflectionEquations, check_campaign, check_load_point, deflection_equations
from bayescal.inference.exact import SETTLED_SD, UNCONVERGED_SD, ExactCorrection, moved_point
from bayescal.inference.fit_checks import calibration_lack_of_fit, campaign_identifiability, check_scale, listed, practical_identifiability, residual_chi2, unresolved_columns, warn_fit_checks
from bayescal.inference.identifiability import Identifiability, grouped, label_angle
from bayescal.inference.posterior import posterior_density, sample_posterior, sampler_coordinates
from bayescal.inference.priors import GeometryPrior, config_geometry
from bayescal.inference.results import ElastostaticDraws, ElastostaticResults, edge_point, linearisation_attrs, stored_point
from bayescal.inference.samplers import elastostatic_sampler
from bayescal.cell.config import DEFAULT_COMPENSATED_JOINT
from bayescal.robot.kinematics import Robot
from bayescal.sampling.protocol import Sampler
from bayescal.sampling.summary import converged, diagnostics, sample_until_converged, summarize
from bayescal.threads import one_blas_thread
from bayescal.robot.compensator import Compensator, law_on
from bayescal.robot.laws import CompensatorLaw, LawParameter

__all__ = ["ElastostaticModel", "restore_results"]

EXTENSIONS = 3
"""Runs after the first that ``bayescal calibrate`` allows by default while R-hat or the ESS fall short: the
collapsed sampler hands over to the Gibbs sampler (:meth:`~bayescal.sampling.collapsed.CollapsedSampler.extended`),
which then doubles its draws, up to 16 × 2,400.  On Table III with twice the twin's link compliance (seeds 0-5),
16 × 600 Gibbs draws left R-hat above 1.01 or the tail ESS under 400 in 2 of 6 campaigns."""
RELINEARISATIONS = 4
"""Most times the exact model's correction is linearised again about the posterior mean of the spring and the link-mass
scale (:meth:`ElastostaticModel._sample`)."""


class _Prepared(NamedTuple):
    """A campaign made ready for sampling: its equations, what they identify and the closed forms."""

    equations: DeflectionEquations
    identifiability: Identifiability
    linear_closed_form: ClosedForm
    offset: np.ndarray
    """Exact minus linear prediction of every equation (m); zeros for the linear model."""
    closed_form: ClosedForm
    iterations: int
    linearised_at: ClosedForm
    """The closed form ``offset`` was computed at: the exact model's linearisation point."""
    point: tuple[float, ...] | None = None
    """``(*law values, mass scale)`` (SI, 1) the correction is linearised about; None: the config's law, the URDF's masses."""


@dataclass
class ElastostaticModel:
    """Identification of the joint compliances and the compensator law's parameters.

    Parameters
    ----------
    robot
        The robot (its URDF gives kinematics and, for the exact model, link masses).
    geometry
        Prior of the compensator geometry ``[L, a_x, a_y, phi]`` (m, rad): from a
        geometry posterior (:meth:`GeometryPrior.from_draws`) or from the config; None
        for a robot without a compensator.
    nominal_compliances
        ``(nq,)`` compliances (rad/(N·m), k2 without compensator) used only by the
        exact model for parameters the campaign cannot identify.
    nominal_spring
        The compensator law's values (SI; ``(K_c, s0)`` in N/m, m for the spring) used by the exact model when the
        compensator is not identifiable; None without a compensator.
    model
        ``"exact"`` (default) or ``"linear"`` (eq 30 as is).
    sampler
        Any sampler of the protocol in :mod:`bayescal.sampling.protocol`; the
        default is :func:`~bayescal.inference.samplers.elastostatic_sampler` ``("collapsed")``.
    noise
        ``"axis"`` (one unknown noise level per base axis) or ``"marker"``.
    load_point
        Flange-frame point (m) where the load's force acts in the exact model.
    tracker
        The tracker's noise model: weights the equations by its distance-dependent
        error and gives the chi-square of the fit against the nominal noise.
        None: equal weights, no chi-square.
    hanging_only
        The cell's end-effector hangs masses only (``cell.loading``): vertical loads are
        no mistake, and k1's not-identifiable reason says so in place of the parallel-loads warning.
    extensions
        Times the sampling may be run again with twice the kept draws per chain while
        R-hat or the ESS fall short of :func:`bayescal.sampling.summary.converged`'s
        thresholds (:func:`bayescal.sampling.summary.sample_until_converged`); 0 never
        extends, ``bayescal calibrate`` uses :data:`EXTENSIONS` unless ``--draws`` is
        given.  A misspecified campaign can leave the default draws short.
    compensated_joint
        Index (0-based) of the joint the compensator acts on: the cell's; None without a
        compensator, when every joint has one constant compliance and nothing is said of the law's parameters.
    law
        The compensator's law (:class:`~bayescal.robot.laws.CompensatorLaw`, the cell's); None: the spring of eqs 4-9.
    """

    robot: Robot
    geometry: GeometryPrior | None
    nominal_compliances: np.ndarray
    nominal_spring: tuple[float, ...] | None
    model: str = "exact"
    sampler: Sampler = field(default_factory=elastostatic_sampler)
    noise: str = "axis"
    load_point: np.ndarray | None = None
    tracker: TrackerNoise | None = None
    max_iterations: int = 10
    hanging_only: bool = False
    extensions: int = 0
    compensated_joint: int | None = DEFAULT_COMPENSATED_JOINT
    law: CompensatorLaw | None = None

    @classmethod
    def from_cell(cls, cell: Cell, geometry: GeometryPrior | None = None, **options) -> ElastostaticModel:
        """A model for a calibration cell: its robot, tool load point, tracker, and nominal stiffness.

        ``geometry`` defaults to :func:`config_geometry` of the cell's compensator (None for a
        cell without one); ``options`` are the other fields (``model``, ``sampler``, ``noise``, ``max_iterations``, ``extensions``).
        """
        if cell.compensator is None:
            if geometry is not None:
                raise ValueError("a compensator geometry was given for a cell without a compensator")
            spring = None
        else:
            spring = cell.compensator.values
            geometry = geometry if geometry is not None else config_geometry(cell.compensator, cell.source)
        return cls(
            robot=cell.robot,
            geometry=geometry,
            nominal_compliances=np.asarray(cell.compliances, dtype=float),
            nominal_spring=spring,
            load_point=cell.load_point,
            tracker=cell.tracker,
            compensated_joint=cell.compensated_joint,
            law=cell.compensator,
            **({"hanging_only": cell.loading.hanging_only} | options),
        )

    @property
    def registry_law(self) -> tuple[LawParameter, ...]:
        """The identified parameters of the compensator's law (the spring's without one)."""
        return (self.law or Compensator).PARAMETERS

    @property
    def _geometry_mean(self) -> np.ndarray | None:
        """The compensator geometry's prior mean ``[L, a_x, a_y, phi]`` (m, rad); None without a compensator."""
        return None if self.geometry is None else self.geometry.mean

    def _exact_at(self, point: tuple[float, ...] | None = None) -> ExactCorrection:
        """The exact model's correction with this model's robot, nominal stiffness and load point, linearised about
        ``point`` ``(*law values, mass scale)`` (SI, 1; None: the config's law and the URDF's masses)."""
        spring, masses = (self.nominal_spring, 1.0) if point is None else (tuple(point[:-1]), float(point[-1]))
        return ExactCorrection(
            self.robot, self.nominal_compliances, self._geometry_mean, spring, self.load_point, self.max_iterations, masses, self.law
        )

    def _nominal_law(self) -> CompensatorLaw | None:
        """The law at the config's values on the geometry prior's mean; None without a compensator or a law."""
        return None if self.law is None or self.geometry is None else law_on(self.law, self.geometry.mean, self.nominal_spring)

    def _static_columns(self, campaign: Campaign, prepared: _Prepared) -> tuple[np.ndarray, np.ndarray] | None:
        """:meth:`ExactCorrection.static_columns` at the closed form the offset of ``prepared`` was computed at; None
        when the link weights are not sampled."""
        # Without an identified compensator the link weights are not sampled: on arm6 masses 15 % heavier move the
        # correction by 0.8 μm rms, against 11 μm of noise per deflection coordinate (docs/elastostatic.md).
        if self.model != "exact" or not prepared.identifiability.compensator:
            return None
        return self._exact_at(prepared.point).static_columns(campaign, prepared.equations, prepared.linearised_at, prepared.offset)

    def _relinearised(self, campaign: Campaign, prepared: _Prepared, point: tuple[float, float, float] | None) -> _Prepared:
        """``prepared`` with the exact model's correction linearised about ``point`` (:meth:`_exact_at`)."""
        cf, offset, iterations, at = self._exact_at(point).relinearise(
            campaign, prepared.equations, prepared.identifiability, prepared.linear_closed_form
        )
        return prepared._replace(offset=offset, closed_form=cf, iterations=iterations, linearised_at=at, point=point)

    @property
    def geometry_source(self) -> str:
        """Where the compensator geometry came from (the DataTree's ``geometry`` attribute)."""
        return "none: the cell has no compensator" if self.geometry is None else self.geometry.source

    def estimate(self, campaign: Campaign) -> tuple[ClosedForm, Identifiability]:
        """Closed-form estimates (eqs 33-34, after the exact model's correction) without sampling."""
        prepared = self._prepare(campaign, announce=False)
        return prepared.closed_form, prepared.identifiability

    def nonlinearity(self, campaign: Campaign) -> np.ndarray:
        """``(3 N,)`` what the exact model adds to the linear one's deflections (m), at its closed-form estimate.

        Zero for the linear model.  A linear analysis of the campaign (the critique's)
        subtracts it from the measured deflections so that the arm's own geometric
        nonlinearity under a heavy load is not mistaken for a misfit.
        """
        return self._prepare(campaign, announce=False).offset

    def _prepare(self, campaign: Campaign, *, announce: bool = True, point: tuple[float, ...] | None = None) -> _Prepared:
        if self.model not in ("exact", "linear"):
            raise ValueError(f"model must be 'exact' or 'linear', got {self.model!r}")
        equations, torque, points = deflection_equations(
            self.robot, campaign, noise=self.noise, tracker=self.tracker, joint=self.compensated_joint, law=self.registry_law
        )
        check_campaign(self.robot, campaign, points, hanging_only=self.hanging_only)
        if announce:
            check_load_point(self.robot, campaign, self.load_point)
        ident = campaign_identifiability(campaign, equations, torque, self._geometry_mean, self.hanging_only, law=self._nominal_law())
        linear_cf = closed_form(equations.whitened(), ident, self._geometry_mean, self._nominal_law())
        check_scale(campaign, linear_cf, self.nominal_compliances)
        unresolved = unresolved_columns(linear_cf, ident, self.nominal_compliances)
        if unresolved:
            ident = campaign_identifiability(campaign, equations, torque, self._geometry_mean, self.hanging_only, unresolved, law=self._nominal_law())
            linear_cf = closed_form(equations.whitened(), ident, self._geometry_mean, self._nominal_law())
        if announce:
            # A limit of the cell, not of the campaign: recorded in k1's reason, said once by `bayescal plan`.
            cell_limit = {k for k, v in ident.reasons.items() if v.endswith(HANGING_ONLY_REASON)}
            for names, reason in grouped({k: v for k, v in ident.reasons.items() if label_angle(k) is None and k not in cell_limit}):
                warnings.warn(f"{listed(names)} not identifiable: {reason}", NotIdentifiableWarning, stacklevel=3)
            if ident.ill_conditioned:
                warnings.warn(
                    f"the campaign is ill-conditioned (condition number {ident.condition_number:.3g} of the unit-column "
                    "design): the intervals are wide and sensitive to the noise model",
                    UserWarning,
                    stacklevel=3,
                )
        prepared = _Prepared(equations, ident, linear_cf, np.zeros(equations.n), linear_cf, 0, linear_cf)
        return self._relinearised(campaign, prepared, point) if self.model == "exact" else prepared

    def fit(self, campaign: Campaign, rng: np.random.Generator | int = 0, checks: bool = True) -> ElastostaticResults:
        """Identify the parameters from ``campaign``; ``rng`` seeds every random draw.  With ``checks`` the fit's checks
        are warnings (:func:`~bayescal.inference.fit_checks.warn_fit_checks`); without, the caller checks what it makes of
        the fit (:mod:`~bayescal.inference.mixture` pools several)."""
        # One BLAS thread, as the command line sets (bayescal/threads.py); a block, not a decorator, so that
        # the warnings' stack levels still name the caller's line.
        with one_blas_thread():
            rng = np.random.default_rng(rng)
            prepared, (tree, draws, residual, n_free), summary, sampler = self._sample(campaign, self._prepare(campaign), rng)
            equations, ident, cf = prepared.equations, prepared.identifiability, prepared.closed_form
            tree.attrs.update(
                {"model": self.model, "noise": self.noise, "sampler": type(sampler).__name__, "geometry": self.geometry_source}
            )
            if prepared.point is not None:
                tree.attrs.update(dict(zip(linearisation_attrs(self.registry_law), edge_point(prepared.point, self.registry_law))))
            if equations.scale is not None:
                residual = residual * equations.scale
            practical = practical_identifiability(summary, equations, ident, cf, self.geometry, self.nominal_spring, self.law)
            # What a later user of the saved posterior (bayescal compensate) must know without the campaign:
            # the robot it belongs to and which sampled parameters the data did not determine.
            tree.attrs.update(
                {
                    "robot": self.robot.model.name,
                    "n_joints": self.robot.nq,
                    "not_identifiable": ",".join(sorted(set(ident.not_identifiable) | set(practical))),
                }
            )
            chi2 = residual_chi2(self.tracker, campaign, residual, n_free)
            misfit = calibration_lack_of_fit(self.tracker, campaign, equations, prepared.offset)
            results = self._results(campaign, prepared, tree, draws, residual, chi2, summary, practical, type(sampler).__name__, misfit)
        if checks:
            warn_fit_checks(results, campaign.source)
        return results

    def _sample(self, campaign: Campaign, prepared: _Prepared, rng: np.random.Generator):
        """Sample ``prepared``, relinearising the exact model's correction about the posterior mean of the spring and the
        link-mass scale while it lies far from the linearisation point (:func:`~bayescal.inference.exact.moved_point`),
        at most :data:`RELINEARISATIONS` times, then extending the sampling while the diagnostics fall short.

        Far from the config's spring, eq 34's closed form of the equations corrected at the config's can leave the
        spring's support: the chains then start at the config's spring, hundreds of posterior sd from the mode along a
        ridge, and do not reach it.  Corrected about the first run's mean, the closed form lands near the mode.
        Returns the prepared campaign last linearised, :func:`sample_posterior`'s output, its summary and the sampler.
        """

        def run(sampler: Sampler) -> tuple:
            corrected = replace(prepared.equations, y=prepared.equations.y - prepared.offset).whitened()
            return sample_posterior(corrected, prepared.identifiability, prepared.closed_form, sampler, self.geometry, self.nominal_spring, rng, static, self.law)

        def moved(output: tuple) -> tuple[float, float, float] | None:
            tolerance = SETTLED_SD if converged(diagnostics(output[0])) else UNCONVERGED_SD
            return moved_point(output[1].spring, output[1].gravity, static[0], tolerance, self._nominal_law())

        static = self._static_columns(campaign, prepared)
        first = run(self.sampler) if static is not None else None
        times = 0
        while static is not None and times < RELINEARISATIONS and (point := moved(first)):
            prepared = self._relinearised(campaign, prepared, point)
            static = self._static_columns(campaign, prepared)
            first = run(self.sampler)
            times += 1
        if times:
            settled = moved(first) is None
            *values, masses = edge_point(prepared.point, self.registry_law)
            where = ", ".join(f"{p.name} = {v:.4g} {p.unit}" for p, v in zip(self.registry_law, values))
            warnings.warn(
                f"{campaign.source}: the posterior's {(self.law or Compensator).kind} and link masses lie far from the config's, about which the exact "
                f"model's correction is first linearised: linearised again {'once' if times == 1 else f'{times} times'}, last about "
                f"{where}, link masses × {masses:.4g}"
                + ("" if settled else " (the posterior mean still moving)"),
                UserWarning,
                stacklevel=3,
            )
        return prepared, *sample_until_converged(run, self.sampler, self.extensions, what="the elastostatic posterior", first=first)

    def restore(self, campaign: Campaign, tree) -> ElastostaticResults:
        """The results of an earlier :meth:`fit` of ``campaign`` from its saved posterior, without sampling again.

        The closed forms, the identifiability and the residuals are recomputed from the
        campaign (they are deterministic); the draws are the tree's.  The model must be
        configured as the one that was fitted (same ``model``, ``noise`` and geometry prior).

        Parameters
        ----------
        campaign
            The campaign the posterior was computed from.
        tree
            The posterior DataTree (:meth:`ElastostaticResults.save` writes it).

        Raises
        ------
        InputError
            When the posterior does not belong to this campaign and model.
        """
        point = stored_point(tree, self.registry_law)
        prepared = self._prepare(campaign, announce=False, point=point)
        try:
            draws = ElastostaticDraws.from_tree(tree, prepared.equations)
        except (KeyError, ValueError) as exc:
            raise InputError(f"the posterior is not one of this campaign and model: {exc}", source=campaign.source) from None
        self._check_restored(campaign, prepared, draws)
        equations, offset, cf = prepared.equations, prepared.offset, prepared.closed_form
        corrected = replace(equations, y=equations.y - offset)
        static = self._static_columns(campaign, prepared)
        whitened = corrected.whitened()
        ident = prepared.identifiability
        posterior, joints = posterior_density(whitened, ident, self.geometry, static, self.law)
        if (static is None) != (draws.gravity is None):
            has = "has" if draws.gravity is not None else "lacks"
            raise InputError(
                f"the posterior {has} the link-weight scale 'gravity_scale', which the {self.model} model of this campaign "
                f"{'does not sample' if draws.gravity is not None else 'samples'}: it comes from another model or an older "
                "bayescal; calibrate again",
                source=campaign.source,
            )
        # The residuals at the posterior mean of the sampled coordinates, as fit computes them.
        residual = posterior.residual(sampler_coordinates(posterior, joints, draws, whitened, ident).mean(axis=0))
        if corrected.scale is not None:
            residual = residual * corrected.scale
        summary = summarize(tree)
        chi2 = residual_chi2(self.tracker, campaign, residual, posterior.ndim - posterior.n_groups)
        practical = practical_identifiability(summary, equations, ident, cf, self.geometry, self.nominal_spring, self.law)
        sampler = str(tree.attrs.get("sampler", "not recorded"))
        misfit = calibration_lack_of_fit(self.tracker, campaign, equations, offset)
        return self._results(campaign, prepared, tree, draws, residual, chi2, summary, practical, sampler, misfit)

    def _check_restored(self, campaign: Campaign, prepared, draws: ElastostaticDraws) -> None:
        """Refuse saved draws that are not of this campaign: their per-angle compliances and compensator against its own."""
        ident = prepared.identifiability
        saved = set(np.flatnonzero(~np.all(np.isnan(draws.k2), axis=(0, 1))).tolist())
        expected = set(range(prepared.equations.compensated_angles.size)) if draws.spring is not None else {
            angle for (_, angle), keep in zip(prepared.equations.per_angle_columns(), ident.identifiable) if angle is not None and keep
        }
        if saved != expected:
            raise InputError(
                f"the posterior is not one of this campaign: it has joint-2 compliances at {len(saved)} q2 angles, "
                f"the campaign identifies them at {len(expected)}",
                source=campaign.source,
            )
        if prepared.identifiability.compensator != (draws.spring is not None):
            raise InputError(
                "the posterior is not one of this campaign: "
                f"it {'has' if draws.spring is not None else 'lacks'} the compensator's {' and '.join(p.name for p in self.registry_law)}, which the campaign "
                f"{'does not determine' if draws.spring is not None else 'determines'}",
                source=campaign.source,
            )

    def _results(self, campaign, prepared, tree, draws, residual, chi2, summary, practical, sampler_name, misfit) -> ElastostaticResults:
        """The results object of a fit or a restored fit."""
        equations, ident, offset, cf = prepared.equations, prepared.identifiability, prepared.offset, prepared.closed_form
        return ElastostaticResults(
            tree=tree,
            identifiability=replace(ident, practical=practical),
            closed_form=cf,
            model=self.model,
            compensated_angles=equations.compensated_angles,
            joint=equations.joint,
            prismatic=equations.prismatic,
            draws=draws,
            geometry=self.geometry,
            n_equations=equations.n,
            n_rows=len(campaign),
            residual_rms=float(np.sqrt(np.mean(residual**2))),
            chi2_per_dof=chi2,
            nonlinearity=float(np.abs(offset).max(initial=0.0)),
            iterations=prepared.iterations,
            residuals=residual.reshape(-1, 3),
            linear_closed_form=prepared.linear_closed_form,
            summary_table=summary,
            sampler_name=sampler_name,
            lack_of_fit=misfit,
            law=self._nominal_law(),
        )

    def chi2_per_dof(self, campaign: Campaign) -> float | None:
        """Chi-square per degree of freedom of the closed-form fit against the tracker's nominal noise.

        The fit is this model's (with the exact model, after its relinearisation).
        The sum runs over the campaign's scalar deflection equations (3 per row),
        each with the variance of two independent tracker readings; the degrees of
        freedom are the equations less the per-angle compliances fitted.  None
        without a tracker noise model.
        """
        prepared = self._prepare(campaign, announce=False)
        equations, ident, offset, cf = prepared.equations, prepared.identifiability, prepared.offset, prepared.closed_form
        corrected = replace(equations, y=equations.y - offset)
        residual = corrected.y - corrected.per_angle_design()[:, ident.identifiable] @ cf.per_angle
        return residual_chi2(self.tracker, campaign, residual, cf.per_angle.size)

def restore_results(cell: Cell, campaign: Campaign, tree, geometry: GeometryPrior | None = None) -> ElastostaticResults:
    """The results of a saved calibration: :meth:`ElastostaticModel.restore` with the model the tree was fitted with.

    Parameters
    ----------
    cell
        The calibration cell of the fit.
    campaign
        The campaign of the fit.
    tree
        The saved posterior; its ``model`` and ``noise`` attributes choose the model
        (files without them: the exact model, and the noise groups' names tell the noise model).
    geometry
        The geometry prior of the fit (``None``: the cell's, as :meth:`ElastostaticModel.from_cell`).
    """
    attrs = tree.attrs
    model = str(attrs.get("model", "exact"))
    if model not in ("exact", "linear"):
        raise InputError(f"the posterior's model attribute is {model!r}, expected 'exact' or 'linear'", source=campaign.source)
    groups = tuple(str(v) for v in tree["posterior"]["noise_group"].values) if "noise_group" in tree["posterior"].coords else ()
    noise = str(attrs.get("noise", "axis" if groups == ("x", "y", "z") else "marker"))
    return ElastostaticModel.from_cell(cell, geometry, model=model, noise=noise).restore(campaign, tree)
