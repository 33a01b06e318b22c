"""Sampling the elastostatic posterior of a campaign's equations.

The density is that of :mod:`~bayescal.inference.likelihood`: per angle (one
compliance per joint and q2 angle) or, when the campaign identifies the
compensator, with joint 2's stiffness ``K_theta2^0 + K_c a L eta(q2; s0)`` of
eq 8.  :func:`sample_posterior` starts the sampler at the closed form (eqs
33-35) with scales from its covariance and returns the draws;
:func:`sampler_coordinates` maps saved draws back to the sampler's coordinates,
so that a saved posterior gives the residuals its fit gave.
"""

from __future__ import annotations

import numpy as np

from bayescal.errors import InputError
from bayescal.inference.closedform import ClosedForm
from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.identifiability import Identifiability
from bayescal.inference.likelihood import compensated_posterior, per_angle_posterior
from bayescal.inference.priors import GeometryPrior
from bayescal.inference.results import ElastostaticDraws
from bayescal.robot.compensator import law_on
from bayescal.robot.laws import CompensatorLaw
from bayescal.sampling.protocol import Sampler

__all__ = ["posterior_density", "sample_posterior", "sampler_coordinates", "GRAVITY_SD"]

LOG_SIGMA_SCALE = 0.05
"""Initial spread of log sigma around the closed form's: its posterior sd at a few hundred equations."""
GRAVITY_SD = 0.2 / 3
"""Prior sd of the scale on the link masses: ±20 % at 3σ, as uncertain as the URDF's mass ESTIMATES."""
REFERENCE_SCALE = 0.005
"""Typical posterior sd of the compensated joint's equivalent stiffness (relative) when the data determine it: with
the law's (:meth:`~bayescal.robot.laws.CompensatorLaw.block_scale`), the scale of the Gibbs sampler's mode search
and of emcee's initial ball."""


def _nominal_start(cf: ClosedForm, q2: np.ndarray, law: CompensatorLaw) -> np.ndarray:
    """``[K_theta2^0, *values]`` with the nominal law and the K_theta2^0 that best fits the per-angle k2."""
    known = np.isfinite(cf.k2) & (cf.k2 > 0)
    K0 = float(np.mean(1.0 / cf.k2[known] - law.stiffness(q2[known])))
    return np.array([K0, *law.values])


def _positive(compliances: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """The closed-form ``compliances``, those not above zero (outside their flat prior's support) replaced by their ``sd``.

    A joint the loads barely turn has a closed form of either sign: k1 of the KR-270 under hanging loads, with A1's
    placement tilted by about 0.08 deg (a geometry identified on the twin) and a closed-form sd 0.92 times the config's
    k1, came out at -0.25 sd.
    """
    return np.where(compliances > 0, compliances, sd)


def posterior_density(equations: DeflectionEquations, ident: Identifiability, geometry: GeometryPrior | None, static=None, law=None):
    """The posterior density of the (whitened) equations and, in the compensated model, the joints it samples.

    Parameters
    ----------
    equations
        The campaign's whitened equations, corrected by the exact model.
    ident
        What the campaign identifies.
    geometry
        The compensator geometry's prior (None without a compensator).
    static
        The exact model's static columns (:meth:`~bayescal.inference.exact_correction.ExactCorrection.static_columns`),
        or None when the link weights are not sampled.
    law
        The compensator's law (:class:`~bayescal.robot.laws.CompensatorLaw`); None: the spring of eqs 4-9.
    """
    if ident.compensator:
        joints = tuple(j for j in range(equations.n_joints) if j != equations.joint and f"k{j + 1}" not in ident.reasons)
        return compensated_posterior(equations, joints, geometry, static, GRAVITY_SD, law), joints
    return per_angle_posterior(equations, ident.identifiable), None


def sample_posterior(
    equations: DeflectionEquations,
    ident: Identifiability,
    cf: ClosedForm,
    sampler: Sampler,
    geometry: GeometryPrior | None,
    nominal_spring: tuple[float, ...] | None,
    rng,
    static=None,
    law: CompensatorLaw | None = None,
):
    """The posterior tree, its draws, the residuals (whitened) at the posterior mean and the number of parameters
    other than the noise levels.

    ``cf`` is the closed form the chains start at; ``nominal_spring`` the compensator ``law``'s values (SI;
    ``(K_c, s0)`` for the spring, the law when None) are their start when eq 34's do not fit; the other arguments
    are those of :func:`posterior_density`.
    """
    sd = np.sqrt(np.diag(cf.cov))
    log_sigma_scale = np.full(cf.sigma.size, LOG_SIGMA_SCALE)
    posterior, joints = posterior_density(equations, ident, geometry, static, law)
    if ident.compensator:
        prior = geometry
        geometry = np.empty(0) if prior.fixed else prior.mean
        gravity = np.ones(int(static is not None))
        columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
        k_sd = np.array([sd[columns.index((j, None))] for j in joints])
        k_start = _positive(cf.compliances[list(joints)], k_sd)

        def start_at(spring: np.ndarray) -> np.ndarray:
            z = posterior.block.coordinates(spring)
            return np.concatenate([k_start, z, gravity, geometry, np.log(cf.sigma)])

        spring = cf.spring
        start = start_at(spring)
        if not np.isfinite(posterior(start)):
            # Eq 34 can return values outside the law's support (a negative K_c or s0) when the data determine
            # them loosely; the chains then start from the nominal law instead.
            spring = _nominal_start(cf, equations.compensated_angles, law_on(law, prior.mean, nominal_spring))
            start = start_at(spring)
        if not np.isfinite(posterior(start)):
            raise InputError(
                "neither the closed-form compensator estimate (eq 34) nor the nominal spring fits the campaign "
                "with a positive joint-2 stiffness: the campaign does not determine the compensator"
            )
        geometry_sd = np.sqrt(np.diag(prior.cov)) if geometry.size else np.empty(0)
        spring_sd = np.concatenate([[REFERENCE_SCALE * abs(start[len(joints)])], posterior.block.law.block_scale(spring[1:])])
        scale = np.concatenate([k_sd, spring_sd, np.full(gravity.size, GRAVITY_SD), geometry_sd, log_sigma_scale])
        raw = sampler.sample(posterior, start, scale, rng)
        draws = ElastostaticDraws.compensated(posterior, joints, raw, equations.joint)
    else:
        start = np.concatenate([_positive(cf.per_angle, sd), np.log(cf.sigma)])
        raw = sampler.sample(posterior, start, np.concatenate([sd, log_sigma_scale]), rng)
        draws = ElastostaticDraws.per_angle(equations, ident.identifiable, raw)
    residual = posterior.residual(raw.reshape(-1, raw.shape[-1]).mean(axis=0))
    return draws.tree(equations), draws, residual, posterior.ndim - posterior.n_groups


def sampler_coordinates(posterior, joints: tuple[int, ...] | None, draws: ElastostaticDraws, equations: DeflectionEquations, ident: Identifiability) -> np.ndarray:
    """``(S, ndim)`` the sampler's coordinates ``[k, z, log sigma]`` of saved draws: the inverse of
    :meth:`ElastostaticDraws.compensated` and :meth:`ElastostaticDraws.per_angle`."""
    sigma = np.log(draws.sigma.reshape(-1, draws.sigma.shape[-1]))
    if joints is None:
        columns = [c for c, keep in zip(equations.per_angle_columns(), ident.identifiable) if keep]
        values = [draws.compliances[f"k{j + 1}"].reshape(-1) if a is None else draws.k2[..., a].reshape(-1) for j, a in columns]
        return np.column_stack([*values, sigma])
    block = posterior.block
    spring = draws.spring.reshape(-1, draws.spring.shape[-1])
    geometry = block.geometry.mean[None, :] if draws.geometry is None else draws.geometry.reshape(-1, 4)
    geometry = np.broadcast_to(geometry, (spring.shape[0], 4))
    reference = block.law.joint_stiffness_of(np.array([block.q_ref]), geometry, spring)[:, 0]
    z = [reference, *block.law.block_coordinates(spring[:, 1:]).T]
    if draws.gravity is not None:
        z.append(draws.gravity.reshape(-1))
    if not block.geometry.fixed:
        z.extend(geometry.T)
    k = [draws.compliances[f"k{j + 1}"].reshape(-1) for j in joints]
    return np.column_stack([*k, *np.broadcast_arrays(*z), sigma])
