"""emcee's affine-invariant ensemble behind the sampler protocol of :mod:`bayescal.sampling.protocol`.

emcee is imported when an ensemble first samples: with ``scipy.stats``,
which it imports, that takes over a second.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from bayescal.sampling.protocol import LogProb

__all__ = ["EnsembleSampler"]


@dataclass(frozen=True)
class EnsembleSampler:
    """emcee's affine-invariant ensemble, run as several independent ensembles.

    Walkers of one ensemble move together and are not independent chains, and
    R-hat computed over the walkers of a single ensemble cannot detect an
    ensemble that as a whole has not forgotten its start.  ``n_chains``
    ensembles are therefore started independently, each from its own random
    ball around ``start``, and each ensemble is one chain of the result: its
    draws run through walker 0's kept steps, then walker 1's, and so on.  R-hat
    then compares independent ensembles, and the autocorrelation that ESS
    sees is the walkers' own.

    Parameters
    ----------
    n_chains
        Number of independent ensembles.
    n_walkers
        Walkers per ensemble; the default is ``max(16, 2 * ndim + 2)`` rounded up to even.
    n_tune
        Steps discarded at the start of each ensemble.
    n_draws
        Steps kept per walker (before thinning).
    thin
        Keep every ``thin``-th step.
    moves
        emcee moves; ``None`` uses emcee's default stretch move.
    """

    n_chains: int = 4
    n_walkers: int | None = None
    n_tune: int = 1000
    n_draws: int = 1000
    thin: int = 1
    moves: Sequence | None = None

    def walkers_for(self, ndim: int) -> int:
        """Number of walkers per ensemble for a posterior of ``ndim`` parameters."""
        n = self.n_walkers if self.n_walkers is not None else max(16, 2 * ndim + 2)
        return n + n % 2

    def describe(self, ndim: int) -> str:
        """One line naming the sampler and its settings, for a posterior file's attributes."""
        if self.moves is None:
            names = "StretchMove"
        else:
            entries = self.moves if isinstance(self.moves, (list, tuple)) else [self.moves]
            names = ", ".join(
                f"{type(entry[0]).__name__} {entry[1]:g}" if isinstance(entry, tuple) else type(entry).__name__ for entry in entries
            )
        return (
            f"emcee, {self.n_chains} independent ensembles of {self.walkers_for(ndim)} walkers, "
            f"{self.n_tune} tuning + {self.n_draws} kept steps, thin {self.thin}, moves {names}"
        )

    def sample(self, log_prob: LogProb, start: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Sample ``exp(log_prob)``.

        Parameters
        ----------
        log_prob
            Log-density of a 1-D parameter vector; ``-inf`` outside the support.
        start
            A point of high posterior density, e.g. the closed-form estimate.
        scale
            Per-parameter standard deviation of the initial ball around ``start``
            (about the posterior sd: too small slows burn-in, too large wastes it).
        rng
            Source of all randomness: the initial balls and each ensemble's seed.

        Returns
        -------
        numpy.ndarray
            Draws of shape ``(n_chains, n_walkers * ceil(n_draws / thin), ndim)``.
        """
        start = np.asarray(start, dtype=float)
        scale = np.broadcast_to(np.asarray(scale, dtype=float), start.shape)
        if not np.isfinite(log_prob(start)):
            raise ValueError("the log-posterior is not finite at the starting point")
        import emcee

        ndim = start.size
        n_walkers = self.walkers_for(ndim)
        chains = []
        for _ in range(self.n_chains):
            ensemble = emcee.EnsembleSampler(n_walkers, ndim, log_prob, moves=self.moves)
            ensemble.random_state = np.random.RandomState(int(rng.integers(2**32 - 1))).get_state()
            initial = self._initial_ball(log_prob, start, scale, n_walkers, rng)
            ensemble.run_mcmc(initial, self.n_tune + self.n_draws, progress=False)
            kept = ensemble.get_chain(discard=self.n_tune, thin=self.thin)
            chains.append(np.swapaxes(kept, 0, 1).reshape(-1, ndim))
        return np.stack(chains)

    @staticmethod
    def _initial_ball(log_prob: LogProb, start: np.ndarray, scale: np.ndarray, n_walkers: int, rng: np.random.Generator) -> np.ndarray:
        # Redraw walkers that land outside the support (e.g. a negative stiffness)
        # rather than shrinking the ball, which would bias the start toward `start`.
        ball = np.empty((n_walkers, start.size))
        for walker in range(n_walkers):
            for _ in range(1000):
                candidate = start + scale * rng.standard_normal(start.size)
                if np.isfinite(log_prob(candidate)):
                    break
            else:
                raise ValueError("could not draw an initial walker inside the support; reduce `scale`")
            ball[walker] = candidate
        return ball
