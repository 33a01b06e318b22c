"""The elastostatic posterior of the compensated model written in JAX, and a NUTS sampler of it (NumPyro).

This is the model a user would write themselves to sample the posterior with a
gradient-based sampler instead of the package's default: the same density as
:class:`~bayescal.sampling.gibbs.ConditionallyLinear` with a
:class:`~bayescal.inference.likelihood.CompensatorBlock` (``theta = [k, z, log
sigma]``, priors in :mod:`bayescal.inference.likelihood`), term by term from the
equations, not through the package's sufficient statistics.
:func:`log_density` is checked against the package's density by
``tests/benchmarks/test_jax_posterior.py`` and at the start of ``bench_nuts.py``.

:class:`NutsSampler` honours the package's sampler protocol, so that
``ElastostaticModel(sampler=NutsSampler())`` samples exactly the posterior the
default sampler does.  NUTS moves in unconstrained, standardised coordinates
``v``: ``log k`` for the compliances (positive), ``logit(s0 / (a + L))`` for the
spring's free length (bounded by the geometry), the other coordinates as they are,
each centred on the start and divided by its scale; the density in ``v`` carries
the log-Jacobian of that map.  Needs the ``bench`` extra (``pip install -e '.[bench]'``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np


# JAX computes in single precision unless told otherwise; the package's density is in double, and the
# residuals are small differences of terms in compliances of ~1e-6 rad/(N·m) and stiffnesses of ~1e6 N·m/rad.
jax.config.update("jax_enable_x64", True)

__all__ = ["log_density", "Unconstrained", "NutsSampler"]


def _regressor(q: jnp.ndarray, L, a_x, a_y, phi) -> jnp.ndarray:
    """``(m, 3)`` rows of eq 35 at the angles ``q`` (rad) for one geometry (m, m, m, rad)."""
    a = jnp.hypot(a_x, a_y)
    gamma = phi - jnp.arctan2(a_y, a_x) - q
    cos, sin = jnp.cos(gamma), jnp.sin(gamma)
    s2 = a**2 + L**2 + 2.0 * a * L * cos
    aL = a * L
    return jnp.stack([jnp.ones_like(gamma), -aL * cos, aL / jnp.sqrt(s2) * (aL / s2 * sin**2 + cos)], axis=-1)


def log_density(posterior):
    """``theta -> log p(theta | y)`` (up to the package's constant) of a compensated posterior, as a JAX function.

    Parameters
    ----------
    posterior
        A :class:`~bayescal.sampling.gibbs.ConditionallyLinear` model whose block is a
        :class:`~bayescal.inference.likelihood.CompensatorBlock` (the compensated model of
        :func:`~bayescal.inference.likelihood.compensated_posterior`, linear or exact).

    Returns
    -------
    callable
        From ``(ndim,)`` ``theta = [k (rad/(N·m)), K_ref (N·m/rad), log K_c (log N/m), s0 (m),
        gravity_scale (exact model), L, a_x, a_y (m), phi (rad) (unless the geometry is fixed),
        log sigma]`` to a scalar; ``-inf`` outside the support.
    """
    block = posterior.block
    p, G = posterior.n_linear, posterior.n_groups
    X, y, b = (jnp.asarray(a, dtype=float) for a in (posterior.X, posterior.y, posterior.b))
    level = jnp.asarray(posterior.level)
    one_hot = jnp.asarray(np.eye(G)[posterior.group])
    counts = jnp.asarray(np.bincount(posterior.group, minlength=G), dtype=float)
    angles = jnp.asarray(np.append(block.q2, block.q_ref))
    mean = jnp.asarray(block.geometry.mean)
    fixed = bool(block.geometry.fixed)
    precision = None if fixed else jnp.asarray(np.linalg.inv(block.geometry.cov))
    static = None if block.static is None else jnp.asarray(block.static)
    W = None if posterior.W is None else jnp.asarray(posterior.W)
    adapted = block.n_adapted

    def value(theta: jnp.ndarray) -> jnp.ndarray:
        k, z, log_sigma = theta[:p], theta[p : theta.size - G], theta[theta.size - G :]
        K_ref, log_K_c, s0 = z[0], z[1], z[2]
        K_c = jnp.exp(log_K_c)
        geometry = mean if fixed else z[adapted : adapted + 4]
        C = _regressor(angles, *geometry)
        change = C[:-1, 1:] - C[-1:, 1:]
        stiffness = K_ref + K_c * (change[:, 0] + change[:, 1] * s0)
        K0 = K_ref - K_c * (C[-1, 1] + C[-1, 2] * s0)
        longest = jnp.hypot(geometry[1], geometry[2]) + geometry[0]
        inside = jnp.all(k > 0) & (K0 > 0) & (s0 > 0) & (s0 < longest) & jnp.all(stiffness > 0)
        # Outside the support the density is -inf; the stiffness is replaced there so that
        # its reciprocal, and the gradient through it, stay finite.
        compliance = 1.0 / jnp.where(inside, stiffness, 1.0)
        fit = X @ k + b * compliance[level]
        prior = log_K_c
        if static is not None:
            gravity = z[1 + block.n_law]
            fit = fit + W @ jnp.stack([K_c - static[0], K_c * s0 - static[1], gravity - static[2]])
            prior = prior - 0.5 * ((gravity - 1.0) / block.gravity_sd) ** 2
        if not fixed:
            d = geometry - mean
            prior = prior - 0.5 * d @ precision @ d
        ssr = ((y - fit) ** 2) @ one_hot
        total = jnp.sum(-counts * log_sigma - 0.5 * ssr * jnp.exp(-2.0 * log_sigma)) + prior
        return jnp.where(inside, total, -jnp.inf)

    return value


@dataclass(frozen=True)
class Unconstrained:
    """The map from NUTS's coordinates ``v`` to ``theta``: ``theta = g(center + scale * v)`` (module docstring).

    ``g`` exponentiates the first ``n_linear`` coordinates and maps the spring's
    free length through ``(a + L) * sigmoid``; every other coordinate passes unchanged.
    """

    center: np.ndarray
    scale: np.ndarray
    n_linear: int
    s0: int
    geometry: int | None
    fixed_geometry: np.ndarray

    @classmethod
    def at(cls, posterior, start: np.ndarray, scale: np.ndarray) -> Unconstrained:
        """Centred on ``start`` ``(ndim,)``, standardised by the posterior sd ``scale`` ``(ndim,)`` carried through ``g``'s inverse."""
        block, p = posterior.block, posterior.n_linear
        s0 = p + block.n_law
        geometry = None if block.geometry.fixed else p + block.n_adapted
        geometry_of_start = block.geometry.mean if geometry is None else start[geometry : geometry + 4]
        longest = float(np.hypot(geometry_of_start[1], geometry_of_start[2]) + geometry_of_start[0])
        center = np.array(start, dtype=float)
        spread = np.array(scale, dtype=float)
        center[:p] = np.log(start[:p])
        spread[:p] = scale[:p] / start[:p]
        center[s0] = np.log(start[s0] / (longest - start[s0]))
        spread[s0] = scale[s0] * longest / (start[s0] * (longest - start[s0]))
        return cls(center, spread, p, s0, geometry, np.asarray(block.geometry.mean))

    def _longest(self, w: jnp.ndarray) -> jnp.ndarray:
        """``a + L`` (m), the spring's longest length, at the geometry of ``w`` (or the fixed one)."""
        L, a_x, a_y = (self.fixed_geometry if self.geometry is None else w[self.geometry : self.geometry + 4])[:3]
        return jnp.hypot(a_x, a_y) + L

    def theta(self, v: jnp.ndarray) -> jnp.ndarray:
        """``(ndim,)`` ``theta`` at ``(ndim,)`` ``v``."""
        w = jnp.asarray(self.center + self.scale * v)
        p = self.n_linear
        w = w.at[:p].set(jnp.exp(w[:p]))
        return w.at[self.s0].set(self._longest(w) * jax.nn.sigmoid(w[self.s0]))

    def log_jacobian(self, v: jnp.ndarray) -> jnp.ndarray:
        """``log |det d theta / d v|`` up to a constant.

        The map is triangular once the geometry comes before ``s0``: each compliance
        depends on its own coordinate, ``s0`` on its own and the geometry's.
        """
        w = jnp.asarray(self.center + self.scale * v)
        t = w[self.s0]
        return jnp.sum(w[: self.n_linear]) + jnp.log(self._longest(w)) - jax.nn.softplus(-t) - jax.nn.softplus(t)


@dataclass(frozen=True)
class NutsSampler:
    """NumPyro's NUTS on a compensated elastostatic posterior; honours the sampler protocol ``sample(target, start, scale, rng)``.

    Parameters
    ----------
    n_chains
        Chains, run one after another; each starts at ``v`` drawn
        from a standard normal, i.e. dispersed by about the posterior sd around the start.
    n_warmup
        Warm-up iterations per chain (step size and mass matrix adaptation), discarded.
    n_draws
        Iterations kept per chain.
    target_accept
        NUTS's target acceptance probability (NumPyro's default 0.8).
    dense_mass
        Adapt a dense mass matrix rather than a diagonal one.
    record
        Filled by :meth:`sample`, wall times in s: ``init_seconds`` (NumPyro's initial state of every
        chain, run op by op), ``compile_seconds`` (tracing and compiling the chains' loop),
        ``loop_seconds`` (running it for every chain); ``gradients`` (leapfrog steps of the kept draws, all chains),
        ``divergences`` (among the kept draws).
    """

    n_chains: int = 4
    n_warmup: int = 1000
    n_draws: int = 1000
    target_accept: float = 0.8
    dense_mass: bool = False
    record: dict = field(default_factory=dict, compare=False)

    def describe(self, ndim: int) -> str:
        """One line naming the sampler and its settings."""
        mass = "dense" if self.dense_mass else "diagonal"
        return (
            f"NumPyro NUTS ({mass} mass matrix, target acceptance {self.target_accept:g}); {ndim} parameters, "
            f"{self.n_chains} chains of {self.n_warmup} warm-up + {self.n_draws} kept iterations"
        )

    def sample(self, target, start: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draws ``(chain, draw, ndim)`` of ``theta``; see :func:`log_density` for the targets it takes.

        Each chain is NumPyro's NUTS kernel, with its warm-up adaptation, stepped by one
        ``lax.scan`` over warm-up and kept iterations (``numpyro.infer.MCMC`` steps the same
        kernel in a loop of its own), compiled once for all chains ahead of time, so that
        the compilation is timed apart.
        """
        from numpyro.infer import NUTS

        start = np.asarray(start, dtype=float)
        coordinates = Unconstrained.at(target, start, np.broadcast_to(np.asarray(scale, dtype=float), start.shape))
        density = log_density(target)

        def potential(v: jnp.ndarray) -> jnp.ndarray:
            return -(density(coordinates.theta(v)) + coordinates.log_jacobian(v))

        kernel = NUTS(potential_fn=potential, target_accept_prob=self.target_accept, dense_mass=self.dense_mass)

        def chain(state):
            def step(state, _):
                state = kernel.sample(state, (), {})
                return state, (state.z, state.num_steps, state.diverging)

            return jax.lax.scan(step, state, None, length=self.n_warmup + self.n_draws)[1]

        keys = jax.random.split(jax.random.PRNGKey(int(rng.integers(2**31))), self.n_chains)
        starts = rng.standard_normal((self.n_chains, start.size))
        began = time.perf_counter()
        states = [kernel.init(key, self.n_warmup, init_params=jnp.asarray(v)) for key, v in zip(keys, starts)]
        initialised = time.perf_counter()
        compiled = jax.jit(chain).lower(states[0]).compile()
        loop = time.perf_counter()
        v, steps, diverging = (np.stack(a)[:, self.n_warmup :] for a in zip(*(jax.block_until_ready(compiled(s)) for s in states)))
        self.record.update(
            init_seconds=initialised - began,
            compile_seconds=loop - initialised,
            loop_seconds=time.perf_counter() - loop,
            gradients=int(steps.sum()),
            divergences=int(diverging.sum()),
        )
        return np.asarray(jax.vmap(jax.vmap(coordinates.theta))(jnp.asarray(v)))
