"""What a sampler is: a small object that turns a target density and a start into draws.

A sampler is any object with ``sample(target, start, scale, rng)`` returning
draws of shape ``(chain, draw, ndim)``.  ``target`` is a log-posterior: a
callable from a 1-D parameter vector to a float (``-inf`` outside the
support).  A sampler that exploits structure accepts the targets whose
structure it knows (the Gibbs sampler takes
:class:`~bayescal.sampling.gibbs.ConditionallyLinear` models, which are
callable log-posteriors too), so one model can be sampled by either.  Models
take a sampler as an argument, the way emcee takes its moves, and never ask
which one they were given.

A target with a true attribute ``vectorized`` also takes a batch ``(n, ndim)``
and returns ``(n,)`` values; samplers that can use batches then evaluate it
once per batch (see :func:`bayescal.sampling.independence.evaluate`).  A
sampler may offer ``describe(ndim)``, a one-line account of its settings for
result files, and ``extended()``, the sampler to run instead when its draws fall
short of convergence (:func:`bayescal.sampling.summary.sample_until_converged`;
without it, the same sampler with twice its ``n_draws``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

__all__ = ["Sampler", "LogProb"]

LogProb = Callable[[np.ndarray], float]


class Sampler(Protocol):
    """What a model needs from a sampler."""

    def sample(self, target: LogProb, start: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draws of shape ``(chain, draw, ndim)`` from ``exp(target)``.

        ``start`` is a point of high posterior density (e.g. a closed-form
        estimate) and ``scale`` the typical posterior sd of each parameter.
        """
        ...
