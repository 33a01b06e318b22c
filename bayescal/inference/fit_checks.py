"""What a campaign and its elastostatic fit say about themselves.

Before sampling: whether the campaign determines any compliance and its noise
(:func:`check_determined`), and whether its deflections are in the units the
columns name (:func:`check_scale`).  After: how the residuals compare with the
tracker's nominal noise (:func:`residual_chi2`) and with the scatter of the
repeats (:func:`calibration_lack_of_fit`), and which sampled parameters the data
did determine (:func:`practical_identifiability`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.tracker import TrackerNoise
from bayescal.errors import InputError, NotIdentifiableWarning
from bayescal.inference.closedform import ClosedForm, check_regression
from bayescal.inference.equations import HANGING_ONLY_REASON, DeflectionEquations, deflection_noise
from bayescal.inference.identifiability import Identifiability, analyse, grouped, label_angle, practical_reasons, rule_clause
from bayescal.inference.lack_of_fit import LackOfFit, least_squares_lack_of_fit, line_of_sight, replicate_cells
from bayescal.inference.priors import GeometryPrior
from bayescal.robot.compensator import Compensator, law_on
from bayescal.robot.laws import CompensatorLaw
from bayescal.sampling.summary import diagnostics, warn_if_unconverged
from bayescal.units import URAD_PER_NM

__all__ = ["check_fits_campaign", "MAX_CHI2_PER_DOF", "campaign_identifiability", "check_determined", "check_scale", "unresolved_columns", "UNRESOLVED_RATIO", "residual_chi2", "calibration_lack_of_fit", "practical_identifiability", "warn_fit_checks", "listed", "CHI2_TOLERANCE"]

CHI2_TOLERANCE = 2.0
"""chi2/dof of the fit against the config's tracker model beyond which (or below whose inverse) the tracker model
is reported as not describing the data: with a few hundred equations chi2/dof has an sd below 0.1."""
IMPLAUSIBLE_RATIO = 100.0
"""Factor between the compliances a campaign implies and the config's beyond which the data are taken to be in
another unit: joints of one robot model differ by tens of percent, a unit slip by 1000 (m, μm against mm)."""
UNRESOLVED_RATIO = 1.0
"""Closed-form sd of a compliance, as a multiple of the config's, beyond which the campaign does not resolve it: the data
cannot tell the joint from a rigid one or from one twice as compliant.  A joint-1 placement tilted from the vertical lets a
hanging load's force pass a little off joint 1's axis: on the twin's Table III measured three times (seed 1) a tilt of 0.001 deg
gives k1 an sd 170 times the config's k1, 0.05 deg 3.4 times, 0.5 deg 0.37 times, while the joints the loads do turn are
resolved to 0.003-0.035 times theirs; kept, such a column's estimate is noise of either sign (k1 = -88 μrad/(N·m) at 0.001 deg)."""
DETERMINED_FRACTION = 0.25
"""Closed-form sd, as a fraction of the estimate, under which a compliance counts in the unit check."""


def calibration_lack_of_fit(
    tracker: TrackerNoise | None, campaign: Campaign, equations: DeflectionEquations, offset: np.ndarray | float = 0.0
) -> LackOfFit | None:
    """The lack-of-fit test of the calibration model against the repeats' scatter (None without repeats).

    The model is eq 30 with the compensated joint's compliance free at every angle,
    which nests eq 8's for any spring: the test asks whether the linear VJM misses
    the configurations, whatever the compensator, and it is the test ``critique``
    makes of the model before any extension.  It is fitted by weighted least squares
    in each reading's line-of-sight frame (:func:`~bayescal.inference.lack_of_fit.least_squares_lack_of_fit`),
    the F distribution's assumption, rather than taken at the posterior mean: the
    posterior mean's residuals rejected 7 of 60 twin campaigns without an effect at
    the 5 % level (``docs/critique.md``).

    Parameters
    ----------
    tracker
        The cell's tracker, whose position sets the line of sight (None: the base axes).
    campaign
        The campaign the ``equations`` are of.
    equations
        Its equations (:func:`~bayescal.inference.equations.deflection_equations`), not whitened.
    offset
        ``(3 N,)`` the exact model's nonlinearity (m) removed from the observations, or 0 for the linear model.
    """
    scale = np.ones(equations.n) if equations.scale is None else equations.scale
    frames = None if tracker is None else line_of_sight(campaign.p0, tracker.position)
    cells = replicate_cells(campaign.config, campaign.marker)
    return least_squares_lack_of_fit(equations.per_angle_design(), equations.y - offset, scale, cells, frames)


def residual_chi2(tracker: TrackerNoise | None, campaign: Campaign, residual: np.ndarray, n_free: int) -> float | None:
    """Chi-square per degree of freedom of the ``(3 N,)`` residuals (m) against the tracker's nominal noise; None without one."""
    if tracker is None:
        return None
    normalised = residual / np.repeat(deflection_noise(tracker, campaign), 3)
    return float(normalised @ normalised / (residual.size - n_free))


def practical_identifiability(
    summary: pd.DataFrame,
    equations: DeflectionEquations,
    ident: Identifiability,
    cf: ClosedForm,
    geometry: GeometryPrior | None,
    nominal_spring: tuple[float, ...] | None,
    law: CompensatorLaw | None = None,
) -> dict[str, str]:
    """Practical identifiability of the sampled parameters (:func:`~bayescal.inference.identifiability.practical_reasons`),
    from the posterior's summary.

    ``geometry`` (the compensator geometry's prior) bounds the law's flat priors (s0's); ``nominal_spring``, the
    values of the compensator's ``law`` (SI; ``(K_c, s0)`` for the spring, None's law), sets the scale of the
    reason of its first parameter (K_c's).
    """
    prior_sd: dict[str, float | None] = {name: None for name in equations.registry.names}
    requires: dict[str, str] = {}
    through: dict[str, str] = {}
    context = {}
    if geometry is not None:
        law = law_on(law, geometry.mean, nominal_spring)
        prior_sd |= law.prior_sd()
        requires, through = dict(law.REQUIRES), dict(law.THROUGH)
        first = law.PARAMETERS[0].name
        if first in summary.index:
            k2 = summary.loc[f"k{equations.joint + 1}", "mean"] * URAD_PER_NM
            context[first] = _compensator_context(equations, ident, cf, k2, law)
    prior_sd |= {name: None for name in summary.index if label_angle(name) is not None}
    return practical_reasons(summary, prior_sd, requires=requires, context=context, through=through)


def _compensator_context(equations, ident, cf, k2: float, law: CompensatorLaw) -> str:
    """How much the compensator changes the joint-2 stiffness, against how finely the per-angle compliances are known."""
    share = 100.0 * np.abs(law.stiffness(equations.compensated_angles)) * k2
    columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
    sd = np.sqrt(np.diag(cf.cov))
    resolution = [300.0 * sd[i] / cf.per_angle[i] for i, (joint, _) in enumerate(columns) if joint == equations.joint]
    j = equations.joint + 1
    return (
        f"the compensator changes the joint-{j} stiffness by {share.min():.2f}–{share.max():.2f} % across the "
        f"campaign's {equations.compensated_angles.size} q{j} angles (at the config's "
        f"{', '.join(f'{p.name} = {v / p.si_factor:.4g} {p.unit}' for p, v in zip(law.PARAMETERS, law.values))}), "
        f"while the per-angle joint-{j} compliances are resolved to "
        f"±{np.median(resolution):.2f} % (3σ, median over the angles)"
    )


def check_determined(campaign: Campaign, equations: DeflectionEquations, ident: Identifiability) -> None:
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


def check_scale(campaign: Campaign, cf: ClosedForm, nominal: np.ndarray) -> None:
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


def unresolved_columns(cf: ClosedForm, ident: Identifiability, nominal: np.ndarray) -> dict[int, str]:
    """Per-angle columns kept by ``ident`` whose closed-form sd exceeds :data:`UNRESOLVED_RATIO` times the config's compliance.

    Parameters
    ----------
    cf
        The closed form (eq 33) on the columns ``ident`` keeps.
    ident
        What the design identifies structurally.
    nominal
        ``(nq,)`` the config's compliances (rad/(N·m); the compensated joint's ``1/K_theta2^0``).

    Returns
    -------
    dict
        Index into the per-angle columns → the reason, for :func:`~bayescal.inference.identifiability.analyse`.
    """
    sd = np.sqrt(np.diag(cf.cov))
    unresolved = {}
    for i, (joint, _), s in zip(np.flatnonzero(ident.identifiable), cf.columns, sd):
        ratio = s / nominal[joint]
        if ratio > UNRESOLVED_RATIO:
            unresolved[int(i)] = (
                f"the loads barely move joint {joint + 1}: the campaign resolves {ident.names[i]} only to "
                f"±{ratio:.3g} times the config's value (1σ of the closed form, eq 37)"
            )
    return unresolved


def campaign_identifiability(
    campaign: Campaign,
    equations: DeflectionEquations,
    torque: np.ndarray,
    geometry: np.ndarray | None,
    hanging_only: bool,
    unresolved: dict[int, str] | None = None,
    law: CompensatorLaw | None = None,
) -> Identifiability:
    """What ``equations`` identify (:func:`~bayescal.inference.identifiability.analyse`), with the ``unresolved``
    columns (:func:`unresolved_columns`) set apart, the eq 34 regressor checked, and refused when nothing is determined.

    ``torque`` ``(N, nq)`` the loads' joint torques of every row (N·m); ``geometry`` the compensator's ``[L, a_x, a_y, phi]``
    (m, rad; None without one); ``hanging_only`` the cell's end-effector hangs masses only (k1's reason says so);
    ``law`` the compensator's law (None: the spring of eqs 4-9).
    """
    configs = np.unique(campaign.config, return_index=True)[1]
    ident = analyse(
        equations.whitened().per_angle_design(),
        equations.per_angle_columns(),
        equations.compensated_angles,
        torque[configs],
        equations.angle[3 * configs],
        equations.prismatic,
        unresolved,
        law or Compensator,
    )
    ident = replace(ident, rule_clause=rule_clause(law or Compensator))
    if hanging_only and "k1" in ident.reasons:
        ident.reasons["k1"] += f"; {HANGING_ONLY_REASON}"
    if ident.compensator:
        ident = check_regression(ident, equations.per_angle_columns(), equations.compensated_angles, geometry, law)
    check_determined(campaign, equations, ident)
    return ident


MAX_CHI2_PER_DOF = 100.0
"""Largest χ²/dof of a calibration against the campaign and cell given beside it: residuals 10 times the
tracker noise the cell states.  A short calibration of the twin's Table III campaign gives 0.87 on that
campaign and 3588 beside a campaign of the same plan on a robot twice as compliant (tests/cli/test_hostile.py)."""


def check_fits_campaign(results, campaign: str, cell: str, calibration: str) -> None:
    """Refuse a calibration (from the file ``calibration``, restored on the files ``campaign`` and ``cell``) whose χ²/dof
    against them shows it was computed from other data."""
    chi2 = results.diagnostics().get("chi2_per_dof")
    if chi2 is not None and chi2 > MAX_CHI2_PER_DOF:
        raise InputError(
            f"the calibration fits the campaign {campaign} with χ²/dof = {chi2:.2f}, above {MAX_CHI2_PER_DOF:g} (residuals "
            f"{chi2 ** 0.5:.0f} times the tracker noise of {cell}): was it computed from this campaign and cell?",
            source=calibration,
        )


def warn_fit_checks(results, source: str, stacklevel: int = 3) -> None:
    """An elastostatic fit's checks as warnings: the sampled parameters the data did not determine, a posterior short of
    convergence, residuals the config's tracker model does not describe (chi2/dof beyond :data:`CHI2_TOLERANCE`), and
    repeats the model misses.  ``results`` is an :class:`~bayescal.inference.results.ElastostaticResults` of the
    campaign read from ``source``; the warnings name the frame ``stacklevel`` counts from this function (3: the line
    that called its caller, the fit)."""
    for names, reason in grouped(results.identifiability.practical):
        warnings.warn(f"{listed(names)} not identifiable from these data: {reason}", NotIdentifiableWarning, stacklevel=stacklevel)
    warn_if_unconverged(diagnostics(results.tree, results.summary_table), what="the elastostatic posterior", stacklevel=stacklevel + 1)
    chi2 = results.chi2_per_dof
    if chi2 is not None and not 1 / CHI2_TOLERANCE < chi2 < CHI2_TOLERANCE:
        warnings.warn(
            f"{source}: the residuals are {math.sqrt(chi2):.2f} times the tracker noise of the config "
            f"(chi2/dof {chi2:.3g}): the config's tracker model does not describe these data "
            f"({'a larger error, or a misfit of the model' if chi2 > 1 else 'a noise model too pessimistic'}); "
            "the intervals use the noise the data show",
            UserWarning,
            stacklevel=stacklevel,
        )
    misfit = results.lack_of_fit
    if misfit is not None and misfit.significant():
        warnings.warn(
            f"{source}: the model misses the repeated configurations: {misfit.describe()}; "
            "bayescal critique names the likely cause",
            UserWarning,
            stacklevel=stacklevel,
        )


def listed(names: list[str]) -> str:
    """``"k1 is"`` or ``"k2, K_c, s0 are"``."""
    return f"{', '.join(names)} {'is' if len(names) == 1 else 'are'}"
