"""The samplers of the elastostatic posterior and the sizes they run at by default.

:class:`~bayescal.inference.elastostatic.ElastostaticModel` takes any sampler of the
protocol in :mod:`bayescal.sampling.protocol`; :func:`elastostatic_sampler` names the three
this package sizes for the elastostatic posterior, so that the command line and the
studies ask for one by name; :func:`bayescal.geometry.posterior.geometry_sampler`
does the same, with the same arguments, for the geometry posterior.
"""

from __future__ import annotations

from bayescal.sampling.collapsed import CollapsedSampler
from bayescal.sampling.gibbs import GibbsSampler
from bayescal.sampling.protocol import Sampler

__all__ = ["elastostatic_sampler"]

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


def elastostatic_sampler(name: str = "collapsed", *, n_chains: int | None = None, n_tune: int | None = None, n_draws: int | None = None) -> Sampler:
    """The sampler of a name, sized for the elastostatic posterior.

    Parameters
    ----------
    name
        ``"collapsed"`` (the default: batched independence proposals for the nonlinear block and noise
        levels, the compliances drawn exactly; :class:`~bayescal.sampling.collapsed.CollapsedSampler`),
        ``"gibbs"`` (exact conditional draws, sweep by sweep) or ``"emcee"``.
    n_chains
        Independent chains (ensembles for emcee); default :data:`COLLAPSED_CHAINS`,
        :data:`GIBBS_CHAINS` or :data:`EMCEE_CHAINS`.
    n_tune
        Steps discarded per chain; default the collapsed sampler's own, :data:`GIBBS_TUNE` or
        :data:`EMCEE_TUNE`.
    n_draws
        Draws kept per chain (default :data:`COLLAPSED_DRAWS`, :data:`GIBBS_DRAWS`) or, divided by 4,
        steps kept per walker (emcee; default :data:`EMCEE_DRAWS`), so that the same number gives
        comparable effective sample sizes.
    """
    if name == "collapsed":
        return CollapsedSampler(
            n_chains=n_chains or COLLAPSED_CHAINS,
            n_tune=CollapsedSampler.n_tune if n_tune is None else int(n_tune),
            n_draws=COLLAPSED_DRAWS if n_draws is None else int(n_draws),
        )
    if name == "gibbs":
        draws = GIBBS_DRAWS if n_draws is None else int(n_draws)
        return GibbsSampler(n_chains=n_chains or GIBBS_CHAINS, n_tune=GIBBS_TUNE if n_tune is None else int(n_tune), n_draws=draws)
    if name == "emcee":
        from bayescal.sampling.ensemble import EnsembleSampler

        draws = EMCEE_DRAWS if n_draws is None else max(int(n_draws) // 4, 1)
        return EnsembleSampler(n_chains=n_chains or EMCEE_CHAINS, n_tune=EMCEE_TUNE if n_tune is None else int(n_tune), n_draws=draws)
    raise ValueError(f"sampler must be 'collapsed', 'gibbs' or 'emcee', got {name!r}")
