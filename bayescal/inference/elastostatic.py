"""Elastostatic identification: joint compliances and the compensator's spring from a campaign.

Klimchik et al., section V.  ``ElastostaticModel(...).fit(campaign)`` builds
the campaign's equations (:mod:`~bayescal.inference.equations`), analyses what
they identify (:mod:`~bayescal.inference.identifiability`), solves the closed
forms of eqs 33-35 (:mod:`~bayescal.inference.closedform`), corrects the
deflections by the exact model (:mod:`~bayescal.inference.exact`), samples the
posterior of ``k1, k3..k6, K_theta2^0, K_c, s0`` with the joint-2 stiffness
``K_theta2^0 + K_c a L eta(q2; s0)`` of eq 8 (:mod:`~bayescal.inference.likelihood`)
with the sampler it was given, and returns
:class:`~bayescal.inference.results.ElastostaticResults`.

The *exact* model (the default) replaces the linearisation of eq 30 by the
static equilibrium of the virtual joint model with gravity and the
compensator: the difference between the exact and the linear prediction at
the current estimate is subtracted from the measured deflections and the
linear problem is solved again, until the estimate no longer moves.  The
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

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError, NotIdentifiableWarning
from bayescal.inference.closedform import ClosedForm, check_regression, closed_form
from bayescal.inference.equations import HANGING_ONLY_REASON, DeflectionEquations, check_campaign, check_load_point, deflection_equations, deflection_noise
from bayescal.inference.exact import linearisation_offset, scale_masses
from bayescal.inference.identifiability import Identifiability, analyse, grouped, label_angle, practical_reasons
from bayescal.inference.lack_of_fit import LackOfFit, lack_of_fit, replicate_cells
from bayescal.inference.likelihood import compensated_posterior, per_angle_posterior
from bayescal.inference.priors import GeometryPrior, config_geometry
from bayescal.inference.results import ElastostaticDraws, ElastostaticResults
from bayescal.cell.config import DEFAULT_COMPENSATED_JOINT
from bayescal.robot.compensator import CompensatorGeometry, stiffness_regressor
from bayescal.robot.kinematics import Robot
from bayescal.sampling.collapsed import CollapsedSampler
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.sampling.protocol import Sampler
from bayescal.sampling.summary import diagnostics, sample_until_converged, summarize, warn_if_unconverged
from bayescal.units import MM, N_PER_MM, URAD_PER_NM

__all__ = ["ElastostaticModel", "default_sampler", "restore_results"]

COLLAPSED_CHAINS = 32
"""Chains of the default sampler: independence chains cost nothing to add, and R-hat over 32 short chains
is steadier than over 16 long ones (:class:`~bayescal.sampling.collapsed.CollapsedSampler`'s notes)."""
COLLAPSED_DRAWS = 600
"""Draws kept per chain by the default sampler."""
GIBBS_CHAINS = 16
"""Gibbs chains: run together, vectorised, so that a sweep of 16 costs little more than one of 8 and the
proposal refits pool twice the draws."""
GIBBS_TUNE = 100
"""Gibbs iterations discarded per chain: the independence proposal, refitted to the pooled chains, settles
within a hundred."""
GIBBS_DRAWS = 600
"""Gibbs iterations kept per chain.  R-hat needs long chains more than many: the weakly determined spring
parameters keep an autocorrelation time of a few iterations, which raises split R-hat by about that time over
the chain length, and 24 × 300 draws gave R-hat 1.011-1.013.  On the Table III campaign 16 × 600 draws gave a
smallest bulk ESS of 2,399-2,888 and R-hat ≤ 1.0095 (seeds 0-7), against 1,305-1,502 and R-hat ≤ 1.006 for
8 × 800 with two random-walk steps a sweep, at about 60 % of its time."""
EMCEE_CHAINS = 4
"""emcee ensembles, each one chain of the result."""
EMCEE_DRAWS = 200
"""emcee steps kept per walker by default."""
EMCEE_TUNE = 1000
"""emcee steps discarded per ensemble: its autocorrelation times here are a few tens of steps."""
LOG_SIGMA_SCALE = 0.05
"""Initial spread of log sigma around the closed form's: its posterior sd at a few hundred equations."""
GRAVITY_SD = 0.2 / 3
"""Prior sd of the scale on the link masses: ±20 % at 3σ, as uncertain as the URDF's mass ESTIMATES."""
STATIC_STEPS = (0.05, 0.05, 0.05)
"""Finite-difference steps of the static columns: relative in K_c and K_c s0, absolute in the mass scale;
the correction is linear in all three to well within this (the compensator torque is linear in K_c and K_c s0, eq 7)."""
IMPLAUSIBLE_RATIO = 100.0
"""Factor between the compliances a campaign implies and the config's beyond which the data are taken to be in
another unit: joints of one robot model differ by tens of percent, a unit slip by 1000 (m, μm against mm)."""
DETERMINED_FRACTION = 0.25
"""Closed-form sd, as a fraction of the estimate, under which a compliance counts in the unit check."""
CHI2_TOLERANCE = 2.0
"""chi2/dof of the fit against the config's tracker model beyond which (or below whose inverse) the tracker model
is reported as not describing the data: with a few hundred equations chi2/dof has an sd below 0.1."""
EXTENSIONS = 3
"""Runs after the first that ``bayescal calibrate`` allows by default while R-hat or the ESS fall short: the
collapsed sampler hands over to the Gibbs sampler (:meth:`~bayescal.sampling.collapsed.CollapsedSampler.extended`),
which then doubles its draws, up to 16 × 2,400.  On Table III with twice the twin's link compliance (seeds 0-5),
16 × 600 Gibbs draws left R-hat above 1.01 or the tail ESS under 400 in 2 of 6 campaigns."""
SPRING_SCALE = np.array([0.005, 0.05, 0.02])
"""Typical posterior sd of joint 2's equivalent stiffness (relative), ``log K_c`` and ``s0`` (relative) when the data determine them:
the scale of the Gibbs sampler's mode search and of emcee's initial ball."""


def default_sampler(name: str = "collapsed", n_draws: int | None = None, n_chains: int | None = None) -> Sampler:
    """The sampler of a name, sized for the elastostatic posterior.

    Parameters
    ----------
    name
        ``"collapsed"`` (the default: batched independence proposals for the nonlinear block and noise
        levels, the compliances drawn exactly; :class:`~bayescal.sampling.collapsed.CollapsedSampler`),
        ``"gibbs"`` (exact conditional draws, sweep by sweep) or ``"emcee"``.
    n_draws
        Draws kept per chain (Gibbs; default :data:`GIBBS_DRAWS`) or, divided by 4, steps kept
        per walker (emcee; default :data:`EMCEE_DRAWS`), so that the same number gives
        comparable effective sample sizes.
    n_chains
        Independent chains (ensembles for emcee); default :data:`GIBBS_CHAINS` for Gibbs, 4 for emcee.
    """
    if name == "collapsed":
        return CollapsedSampler(n_chains=n_chains or COLLAPSED_CHAINS, n_draws=COLLAPSED_DRAWS if n_draws is None else int(n_draws))
    if name == "gibbs":
        draws = GIBBS_DRAWS if n_draws is None else int(n_draws)
        return GibbsSampler(n_chains=n_chains or GIBBS_CHAINS, n_tune=GIBBS_TUNE, n_draws=draws)
    if name == "emcee":
        from bayescal.sampling.ensemble import EnsembleSampler

        draws = EMCEE_DRAWS if n_draws is None else max(int(n_draws) // 4, 1)
        return EnsembleSampler(n_chains=n_chains or EMCEE_CHAINS, n_tune=EMCEE_TUNE, n_draws=draws)
    raise ValueError(f"sampler must be 'collapsed', 'gibbs' or 'emcee', got {name!r}")


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


@dataclass
class ElastostaticModel:
    """Identification of the joint compliances and the compensator spring.

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
        ``(K_c, s0)`` (N/m, m) used by the exact model when the compensator is not identifiable;
        None without a compensator.
    model
        ``"exact"`` (default) or ``"linear"`` (eq 30 as is).
    sampler
        Any sampler of the protocol in :mod:`bayescal.sampling.protocol`; the
        default is :func:`default_sampler` ``("collapsed")``.
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
        compensator, when every joint has one constant compliance and nothing is said of K_c and s0.
    """

    robot: Robot
    geometry: GeometryPrior | None
    nominal_compliances: np.ndarray
    nominal_spring: tuple[float, float] | None
    model: str = "exact"
    sampler: Sampler = field(default_factory=default_sampler)
    noise: str = "axis"
    load_point: np.ndarray | None = None
    tracker: TrackerNoise | None = None
    max_iterations: int = 10
    hanging_only: bool = False
    extensions: int = 0
    compensated_joint: int | None = DEFAULT_COMPENSATED_JOINT

    @classmethod
    def from_cell(cls, cell: Cell, geometry: GeometryPrior | None = None, **options) -> ElastostaticModel:
        """A model for a calibration cell: its robot, tool load point, tracker, and nominal stiffness.

        ``geometry`` defaults to :func:`config_geometry` of the cell's compensator (None for a
        cell without one); ``options`` are the other fields (``model``, ``sampler``, ``n_draws`` …).
        """
        if cell.compensator is None:
            if geometry is not None:
                raise ValueError("a compensator geometry was given for a cell without a compensator")
            spring = None
        else:
            spring = (cell.compensator.K_c, cell.compensator.s0)
            geometry = geometry if geometry is not None else config_geometry(cell.compensator, cell.source)
        return cls(
            robot=cell.robot,
            geometry=geometry,
            nominal_compliances=np.asarray(cell.compliances, dtype=float),
            nominal_spring=spring,
            load_point=cell.load_point,
            tracker=cell.tracker,
            compensated_joint=cell.compensated_joint,
            **({"hanging_only": cell.loading.hanging_only} | options),
        )

    @property
    def _geometry_mean(self) -> np.ndarray | None:
        """The compensator geometry's prior mean ``[L, a_x, a_y, phi]`` (m, rad); None without a compensator."""
        return None if self.geometry is None else self.geometry.mean

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

    def _prepare(self, campaign: Campaign, *, announce: bool = True) -> _Prepared:
        if self.model not in ("exact", "linear"):
            raise ValueError(f"model must be 'exact' or 'linear', got {self.model!r}")
        equations, torque, points = deflection_equations(
            self.robot, campaign, noise=self.noise, tracker=self.tracker, joint=self.compensated_joint
        )
        check_campaign(self.robot, campaign, points, hanging_only=self.hanging_only)
        if announce:
            check_load_point(self.robot, campaign, self.load_point)
        configs = np.unique(campaign.config, return_index=True)[1]
        ident = analyse(
            equations.whitened().per_angle_design(),
            equations.per_angle_columns(),
            equations.compensated_angles,
            torque[configs],
            equations.angle[3 * configs],
            equations.prismatic,
        )
        if self.hanging_only and "k1" in ident.reasons:
            ident.reasons["k1"] += f"; {HANGING_ONLY_REASON}"
        if ident.compensator:
            ident = check_regression(ident, equations.per_angle_columns(), equations.compensated_angles, self._geometry_mean)
        _check_determined(campaign, equations, ident)
        if announce:
            # A limit of the cell, not of the campaign: recorded in k1's reason, said once by `bayescal plan`.
            cell_limit = {k for k, v in ident.reasons.items() if v.endswith(HANGING_ONLY_REASON)}
            for names, reason in grouped({k: v for k, v in ident.reasons.items() if label_angle(k) is None and k not in cell_limit}):
                warnings.warn(f"{_listed(names)} not identifiable: {reason}", NotIdentifiableWarning, stacklevel=3)
            if ident.ill_conditioned:
                warnings.warn(
                    f"the campaign is ill-conditioned (condition number {ident.condition_number:.3g} of the unit-column "
                    "design): the intervals are wide and sensitive to the noise model",
                    UserWarning,
                    stacklevel=3,
                )
        linear_cf = closed_form(equations.whitened(), ident, self._geometry_mean)
        _check_scale(campaign, linear_cf, self.nominal_compliances)
        offset = np.zeros(equations.n)
        iterations = 0
        cf = at = linear_cf
        if self.model == "exact":
            cf, offset, iterations, at = self._relinearise(campaign, equations, ident, linear_cf)
        return _Prepared(equations, ident, linear_cf, offset, cf, iterations, at)

    def fit(self, campaign: Campaign, rng: np.random.Generator | int = 0) -> ElastostaticResults:
        """Identify the parameters from ``campaign``; ``rng`` seeds every random draw."""
        rng = np.random.default_rng(rng)
        prepared = self._prepare(campaign)
        equations, ident, offset, cf = prepared.equations, prepared.identifiability, prepared.offset, prepared.closed_form
        corrected = replace(equations, y=equations.y - offset)
        # Without an identified compensator the link weights are not sampled: on arm6 masses 15 % heavier move the
        # correction by 0.8 μm rms, against 11 μm of noise per deflection coordinate (docs/elastostatic.md).
        static = self._static_columns(campaign, equations, prepared) if self.model == "exact" and ident.compensator else None
        (tree, draws, residual, n_free), summary, sampler = sample_until_converged(
            lambda sampler: replace(self, sampler=sampler)._sample(corrected.whitened(), ident, cf, rng, static),
            self.sampler,
            self.extensions,
            what="the elastostatic posterior",
        )
        tree.attrs.update(
            {"model": self.model, "noise": self.noise, "sampler": type(sampler).__name__, "geometry": self.geometry_source}
        )
        if corrected.scale is not None:
            residual = residual * corrected.scale
        practical = self._practical(summary, equations, ident, cf)
        # What a later user of the saved posterior (bayescal compensate) must know without the campaign:
        # the robot it belongs to and which sampled parameters the data did not determine.
        tree.attrs.update(
            {
                "robot": self.robot.model.name,
                "n_joints": self.robot.nq,
                "not_identifiable": ",".join(sorted(set(ident.not_identifiable) | set(practical))),
            }
        )
        for names, reason in grouped(practical):
            warnings.warn(f"{_listed(names)} not identifiable from these data: {reason}", NotIdentifiableWarning, stacklevel=2)
        warn_if_unconverged(diagnostics(tree, summary), what="the elastostatic posterior")
        chi2 = self._chi2_per_dof(campaign, residual, n_free)
        if chi2 is not None and not 1 / CHI2_TOLERANCE < chi2 < CHI2_TOLERANCE:
            warnings.warn(
                f"{campaign.source}: the residuals are {math.sqrt(chi2):.2f} times the tracker noise of the config "
                f"(chi2/dof {chi2:.3g}): the config's tracker model does not describe these data "
                f"({'a larger error, or a misfit of the model' if chi2 > 1 else 'a noise model too pessimistic'}); "
                "the intervals use the noise the data show",
                UserWarning,
                stacklevel=2,
            )
        misfit = self._lack_of_fit(campaign, residual, n_free)
        if misfit is not None and misfit.significant():
            warnings.warn(
                f"{campaign.source}: the model misses the repeated configurations: {misfit.describe()}; "
                "bayescal critique names the likely cause",
                UserWarning,
                stacklevel=2,
            )
        return self._results(campaign, prepared, tree, draws, residual, chi2, summary, practical, type(sampler).__name__, misfit)

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
        prepared = self._prepare(campaign, announce=False)
        try:
            draws = ElastostaticDraws.from_tree(tree, prepared.equations)
        except (KeyError, ValueError) as exc:
            raise InputError(f"the posterior is not one of this campaign and model: {exc}", source=campaign.source) from None
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
                f"it {'has' if draws.spring is not None else 'lacks'} the compensator's K_c and s0, which the campaign "
                f"{'does not determine' if draws.spring is not None else 'determines'}",
                source=campaign.source,
            )
        equations, offset, cf = prepared.equations, prepared.offset, prepared.closed_form
        corrected = replace(equations, y=equations.y - offset)
        static = self._static_columns(campaign, equations, prepared) if self.model == "exact" and ident.compensator else None
        whitened = corrected.whitened()
        posterior, joints = self._posterior(whitened, ident, static)
        if (static is None) != (draws.gravity is None):
            has = "has" if draws.gravity is not None else "lacks"
            raise InputError(
                f"the posterior {has} the link-weight scale 'gravity_scale', which the {self.model} model of this campaign "
                f"{'does not sample' if draws.gravity is not None else 'samples'}: it comes from another model or an older "
                "bayescal; calibrate again",
                source=campaign.source,
            )
        # The residuals at the posterior mean of the sampled coordinates, as fit computes them.
        residual = posterior.residual(_coordinates(posterior, joints, draws, whitened, ident).mean(axis=0))
        if corrected.scale is not None:
            residual = residual * corrected.scale
        summary = summarize(tree)
        chi2 = self._chi2_per_dof(campaign, residual, posterior.ndim - posterior.n_groups)
        practical = self._practical(summary, equations, ident, cf)
        sampler = str(tree.attrs.get("sampler", "not recorded"))
        misfit = self._lack_of_fit(campaign, residual, posterior.ndim - posterior.n_groups)
        return self._results(campaign, prepared, tree, draws, residual, chi2, summary, practical, sampler, misfit)

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
        return self._chi2_per_dof(campaign, residual, cf.per_angle.size)

    def _lack_of_fit(self, campaign: Campaign, residual: np.ndarray, n_free: int) -> LackOfFit | None:
        """The lack-of-fit test of the residuals against the repeats' scatter (None without repeats)."""
        scale = np.ones(residual.size) if self.tracker is None else np.repeat(deflection_noise(self.tracker, campaign), 3)
        return lack_of_fit(residual, scale, replicate_cells(campaign.config, campaign.marker), n_free)

    def _chi2_per_dof(self, campaign: Campaign, residual: np.ndarray, n_free: int) -> float | None:
        if self.tracker is None:
            return None
        normalised = residual / np.repeat(deflection_noise(self.tracker, campaign), 3)
        return float(normalised @ normalised / (residual.size - n_free))

    def _practical(self, summary: pd.DataFrame, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm) -> dict[str, str]:
        """Practical identifiability of the sampled parameters (:func:`~bayescal.inference.identifiability.practical_reasons`),
        from the posterior's summary."""
        prior_sd: dict[str, float | None] = {name: None for name in equations.registry.names if name != "s0"}
        if self.geometry is not None:
            L, a_x, a_y = self.geometry.mean[:3]
            # s0's prior is flat on (0, a + L): its sd is the width over sqrt(12).
            prior_sd["s0"] = (math.hypot(a_x, a_y) + L) / math.sqrt(12.0) / MM
        prior_sd |= {name: None for name in summary.index if label_angle(name) is not None}
        context = {}
        if "K_c" in summary.index:
            context["K_c"] = self._compensator_context(equations, ident, cf, summary.loc[f"k{equations.joint + 1}", "mean"] * URAD_PER_NM)
        return practical_reasons(summary, prior_sd, requires={"s0": "K_c"}, context=context)

    def _compensator_context(self, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm, k2: float) -> str:
        """How much the compensator changes the joint-2 stiffness, against how finely the per-angle compliances are known."""
        Kc, s0 = self.nominal_spring
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(Kc, s0)
        share = 100.0 * np.abs(compensator.stiffness(equations.compensated_angles)) * k2
        columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
        sd = np.sqrt(np.diag(cf.cov))
        resolution = [300.0 * sd[i] / cf.per_angle[i] for i, (joint, _) in enumerate(columns) if joint == equations.joint]
        j = equations.joint + 1
        return (
            f"the compensator changes the joint-{j} stiffness by {share.min():.2f}–{share.max():.2f} % across the "
            f"campaign's {equations.compensated_angles.size} q{j} angles (at the config's K_c = {Kc / N_PER_MM:.4g} N/mm, "
            f"s0 = {s0 / MM:.4g} mm), while the per-angle joint-{j} compliances are resolved to "
            f"±{np.median(resolution):.2f} % (3σ, median over the angles)"
        )

    # ----------------------------------------------------------------- exact model
    def _offset(self, campaign: Campaign, equations: DeflectionEquations, cf: ClosedForm, *, spring=None, robot: Robot | None = None) -> np.ndarray:
        """Exact minus linear prediction of every equation at the closed-form estimate ``cf``.

        The per-angle joint-2 compliances of ``cf`` fix joint 2's stiffness at each
        angle; the compensator's static torque, which with the arm's weight sets
        the sag under which the loads act, is that of ``spring`` ``(K_c, s0)``
        (default: the config's), and the weights those of ``robot`` (default:
        the URDF's).  The compensated model corrects both through
        :meth:`_static_columns`.
        """
        compliances = np.where(np.isfinite(cf.compliances) & (cf.compliances > 0), cf.compliances, self.nominal_compliances)
        if equations.joint is None:
            return linearisation_offset(robot or self.robot, campaign, equations, compliances, cf.k2, None, self.load_point)
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(*(spring or self.nominal_spring))
        nominal_k2 = compensator.equivalent_compliance(equations.compensated_angles, self.nominal_compliances[equations.joint])
        k2 = np.where(np.isfinite(cf.k2) & (cf.k2 > 0), cf.k2, nominal_k2)
        return linearisation_offset(robot or self.robot, campaign, equations, compliances, k2, compensator, self.load_point)

    def _static_columns(self, campaign: Campaign, equations: DeflectionEquations, prepared: _Prepared) -> tuple[np.ndarray, np.ndarray]:
        """The exact model's correction linearised in the compensator's static torque and the link weights.

        Returns the linearisation point ``[K_c, K_c s0]`` (the config's spring)
        and the ``(n, 3)`` derivatives of the correction with respect to
        ``K_c`` (at fixed ``K_c s0``), ``K_c s0`` and a common scale of the link
        masses, by finite differences, divided like the equations by their
        relative noise.  The derivatives are taken at the closed form the offset
        was computed at, so that the offset itself is their base.
        """
        Kc, s0 = self.nominal_spring
        cf, base = prepared.linearised_at, prepared.offset
        dKc, dP, dg = STATIC_STEPS[0] * Kc, STATIC_STEPS[1] * Kc * s0, STATIC_STEPS[2]
        columns = [
            (self._offset(campaign, equations, cf, spring=(Kc + dKc, Kc * s0 / (Kc + dKc))) - base) / dKc,
            (self._offset(campaign, equations, cf, spring=(Kc, s0 + dP / Kc)) - base) / dP,
            (self._offset(campaign, equations, cf, robot=scale_masses(self.robot, 1.0 + dg)) - base) / dg,
        ]
        W = np.column_stack(columns)
        if equations.scale is not None:
            W = W / equations.scale[:, None]
        return np.array([Kc, Kc * s0]), W

    def _relinearise(self, campaign, equations, ident, cf):
        sd = np.sqrt(np.diag(cf.cov))
        offset = np.zeros(equations.n)
        for iteration in range(1, self.max_iterations + 1):
            at = cf
            offset = self._offset(campaign, equations, at)
            updated = closed_form(replace(equations, y=equations.y - offset).whitened(), ident, self._geometry_mean)
            change = np.abs(updated.per_angle - cf.per_angle)
            moved = float(np.max(change / sd))
            cf = updated
            if moved < 1e-3 or np.all(change <= 1e-9 * np.abs(cf.per_angle)):
                return cf, offset, iteration, at
        warnings.warn(
            f"the exact model did not settle in {self.max_iterations} relinearisations (last move {moved:.2g} sd)",
            UserWarning,
            stacklevel=3,
        )
        return cf, offset, self.max_iterations, at

    # ----------------------------------------------------------------- sampling
    def _nominal_start(self, cf: ClosedForm, q2: np.ndarray) -> np.ndarray:
        """``[K_theta2^0, K_c, s0]`` with the nominal spring and the K_theta2^0 that best fits the per-angle k2."""
        Kc, s0 = self.nominal_spring
        compensator = CompensatorGeometry(*self.geometry.mean).with_spring(Kc, s0)
        known = np.isfinite(cf.k2) & (cf.k2 > 0)
        K0 = float(np.mean(1.0 / cf.k2[known] - compensator.stiffness(q2[known])))
        return np.array([K0, Kc, s0])

    def _posterior(self, equations: DeflectionEquations, ident: Identifiability, static=None):
        """The posterior density of the (whitened) equations and, in the compensated model, the joints it samples."""
        if ident.compensator:
            joints = tuple(j for j in range(equations.n_joints) if j != equations.joint and f"k{j + 1}" not in ident.reasons)
            return compensated_posterior(equations, joints, self.geometry, static, GRAVITY_SD), joints
        return per_angle_posterior(equations, ident.identifiable), None

    def _sample(self, equations: DeflectionEquations, ident: Identifiability, cf: ClosedForm, rng, static=None):
        """The posterior tree, its draws, the residuals (whitened) at the posterior mean and the number of parameters
        other than the noise levels."""
        sd = np.sqrt(np.diag(cf.cov))
        log_sigma_scale = np.full(cf.sigma.size, LOG_SIGMA_SCALE)
        posterior, joints = self._posterior(equations, ident, static)
        if ident.compensator:
            geometry = np.empty(0) if self.geometry.fixed else self.geometry.mean
            gravity = np.ones(int(static is not None))

            def start_at(spring: np.ndarray) -> np.ndarray:
                z = posterior.block.coordinates(spring)
                return np.concatenate([cf.compliances[list(joints)], z, gravity, geometry, np.log(cf.sigma)])

            spring = cf.spring
            start = start_at(spring)
            if not np.isfinite(posterior(start)):
                # Eq 34 can return a negative K_c or s0 when the data determine the spring
                # loosely; the chains then start from the nominal spring instead.
                spring = self._nominal_start(cf, equations.compensated_angles)
                start = start_at(spring)
            if not np.isfinite(posterior(start)):
                raise InputError(
                    "neither the closed-form compensator estimate (eq 34) nor the nominal spring fits the campaign "
                    "with a positive joint-2 stiffness: the campaign does not determine the compensator"
                )
            columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
            k_sd = np.array([sd[columns.index((j, None))] for j in joints])
            geometry_sd = np.sqrt(np.diag(self.geometry.cov)) if geometry.size else np.empty(0)
            spring_sd = SPRING_SCALE * np.abs([start[len(joints)], 1.0, spring[2]])
            scale = np.concatenate([k_sd, spring_sd, np.full(gravity.size, GRAVITY_SD), geometry_sd, log_sigma_scale])
            raw = self.sampler.sample(posterior, start, scale, rng)
            draws = ElastostaticDraws.compensated(posterior, joints, raw, equations.joint)
        else:
            start = np.concatenate([cf.per_angle, np.log(cf.sigma)])
            raw = self.sampler.sample(posterior, start, np.concatenate([sd, log_sigma_scale]), rng)
            draws = ElastostaticDraws.per_angle(equations, ident.identifiable, raw)
        residual = posterior.residual(raw.reshape(-1, raw.shape[-1]).mean(axis=0))
        return draws.tree(equations), draws, residual, posterior.ndim - posterior.n_groups


def _coordinates(posterior, joints: tuple[int, ...] | None, draws: ElastostaticDraws, equations: DeflectionEquations, ident: Identifiability) -> np.ndarray:
    """``(S, ndim)`` the sampler's coordinates ``[k, z, log sigma]`` of saved draws: the inverse of
    :meth:`ElastostaticDraws.compensated` and :meth:`ElastostaticDraws.per_angle`."""
    sigma = np.log(draws.sigma.reshape(-1, draws.sigma.shape[-1]))
    if joints is None:
        columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
        values = [draws.compliances[f"k{j + 1}"].reshape(-1) if a is None else draws.k2[..., a].reshape(-1) for j, a in columns]
        return np.column_stack([*values, sigma])
    block = posterior.block
    K0, K_c, s0 = (draws.spring[..., i].reshape(-1) for i in range(3))
    geometry = block.geometry.mean[None, :] if draws.geometry is None else draws.geometry.reshape(-1, 4)
    reference = stiffness_regressor(block.q_ref, *(geometry[:, i] for i in range(4)))
    z = [reference[..., 0] * K0 + reference[..., 1] * K_c + reference[..., 2] * s0 * K_c, np.log(K_c), s0]
    if draws.gravity is not None:
        z.append(draws.gravity.reshape(-1))
    if not block.geometry.fixed:
        z.extend(geometry.T)
    k = [draws.compliances[f"k{j + 1}"].reshape(-1) for j in joints]
    return np.column_stack([*k, *np.broadcast_arrays(*z), sigma])


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


def _check_determined(campaign: Campaign, equations: DeflectionEquations, ident: Identifiability) -> None:
    """Reject a campaign that identifies no compliance, or has too few equations to estimate its noise."""
    if not np.any(campaign.wrench):
        raise InputError("no row of the campaign carries a load (every wrench is zero): nothing deflects", source=campaign.source)
    if not ident.identifiable.any():
        raise InputError(
            f"the campaign identifies no joint compliance ({len(campaign)} rows, design rank {ident.rank} of "
            f"{ident.identifiable.size} columns): measure more configurations",
            source=campaign.source,
        )
    unknowns = int(ident.identifiable.sum()) + len(equations.group_names)
    if equations.n <= unknowns:
        raise InputError(
            f"{equations.n} equations ({len(campaign)} rows x 3 coordinates) cannot determine {int(ident.identifiable.sum())} "
            f"compliances and {len(equations.group_names)} noise levels: measure more markers or configurations",
            source=campaign.source,
        )


def _check_scale(campaign: Campaign, cf: ClosedForm, nominal: np.ndarray) -> None:
    """Reject a campaign whose well-determined compliances are all :data:`IMPLAUSIBLE_RATIO` times the config's, or negative.

    A unit slip scales every deflection alike (positions in m or μm under an
    ``_mm`` header) or flips its sign (the loaded and unloaded columns swapped);
    and so does a wrench of the wrong sign; the compliances it implies are then
    off by the same factor, which no real robot differs from its nominal values by.
    """
    sd = np.sqrt(np.diag(cf.cov))
    ratios = np.array([value / nominal[joint] for value, (joint, _) in zip(cf.per_angle, cf.columns)])
    determined = sd < DETERMINED_FRACTION * np.abs(cf.per_angle)
    if not determined.any():
        return
    ratio = float(np.median(ratios[determined]))
    if ratio <= 0:
        what = (
            "negative joint compliances: is the wrench's sign flipped (a hanging load has fz_N < 0), or are the unloaded "
            "(x0_mm..z0_mm) and loaded (x1_mm..z1_mm) positions swapped?"
        )
    elif not 1 / IMPLAUSIBLE_RATIO < ratio < IMPLAUSIBLE_RATIO:
        what = (
            f"joint compliances {ratio:.3g} times the config's: are the positions in another unit than mm "
            "(or the config's k_urad_per_Nm in another than μrad/(N·m))?"
        )
    else:
        return
    raise InputError(f"the campaign's deflections imply {what}", source=campaign.source)


def _listed(names: list[str]) -> str:
    """``"k1 is"`` or ``"k2, K_c, s0 are"``."""
    return f"{', '.join(names)} {'is' if len(names) == 1 else 'are'}"


