"""Gibbs sampling of conditionally linear-Gaussian models, all chains at once.

The deflection model of a calibration campaign is linear in the joint
compliances ``k`` once the noise levels and a small nonlinear block ``z`` (the
compensator's spring and geometry) are given::

    y_i = X_i · k + b_i f(z)[level_i] + W_i · u(z) + e_i,      e_i ~ N(0, sigma_g(i)^2),

with ``k >= 0`` under a flat prior, a Jeffreys prior on each noise variance and
the block's own prior on ``z``.  :class:`ConditionallyLinear` describes such a
model; :class:`GibbsSampler` draws from it.  The compliances have a Gaussian
conditional (truncated to positive values) and each variance an inverse-gamma
one, both drawn exactly.  ``z`` is updated by Metropolis steps on its posterior
with ``k`` integrated out (a partially collapsed Gibbs sampler), which removes
the strong correlation between the block and the compliances that would
otherwise slow the chain: an independence proposal (a Student t fitted at the
mode, then refitted to each chain's own draws during tuning) followed by
random-walk steps; the trailing coordinates that the data barely inform (the
compensator geometry) by an independence proposal from their Gaussian prior.

Every sum over equations is precomputed per noise group, so an iteration costs
the same whatever the number of equations, and every step is vectorised over
the chains.  The collapsed density ignores the positivity truncation of ``k``:
compliances lie many standard deviations from zero.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

__all__ = ["GibbsSampler", "ConditionallyLinear", "NonlinearBlock"]

T_DOF = 5.0
"""Degrees of freedom of the independence proposal: heavy enough tails to cover the posterior's."""
T_INFLATION = 1.2
"""Scale of the independence proposal relative to the fitted covariance."""
RANDOM_WALK_STEPS = 3
"""Random-walk Metropolis steps per sweep after the independence step; they move chains the
independence proposal leaves stuck in the tails."""
REFITS = (0.2, 0.4, 0.6, 0.8)
"""Fractions of the tuning phase at which the proposal is refitted to the second half of the chains'
draws so far, so that it follows the posterior where the Laplace fit is poor."""
START_SPREAD = 0.3
"""sd of the log-normal dispersion of the chains' initial noise variances around the start."""
START_TRIES = 100
"""Draws from the proposal tried per chain for a start inside the support before starting at the caller's point."""


class NonlinearBlock(Protocol):
    """The nonlinear part ``f(z)`` of a :class:`ConditionallyLinear` model.

    Attributes
    ----------
    ndim : int
        Length of ``z``.
    n_adapted : int
        The leading coordinates of ``z``, moved by the adaptive proposal; the
        trailing ``ndim - n_adapted`` have a Gaussian prior ``prior_mean``,
        ``prior_cov`` and are proposed from it.
    """

    ndim: int
    n_adapted: int
    prior_mean: np.ndarray
    prior_cov: np.ndarray

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """At ``(c, ndim)`` points: the ``(c, m)`` coefficients of ``b`` at each level (``nan`` outside the
        support) and the ``(c,)`` log prior density up to a constant, trailing Gaussian included (``-inf`` outside)."""

    def shift(self, z: np.ndarray) -> np.ndarray:
        """``(c, r)`` coefficients ``u(z)`` of the columns ``W`` at ``(c, ndim)`` points (``r = 0`` without ``W``)."""


@dataclass(frozen=True)
class ConditionallyLinear:
    """A linear-Gaussian model with grouped unknown noise and an optional nonlinear block.

    The parameter vector is ``theta = [k, z, log sigma]``; calling the model
    returns its log posterior density (up to a constant), so that any sampler
    of the protocol in :mod:`bayescal.sampling.protocol` can draw from it.

    Parameters
    ----------
    y
        ``(n,)`` observations.
    X
        ``(n, p)`` design of the linear coefficients ``k``.
    group
        ``(n,)`` noise group of each observation, in ``range(n_groups)``.
    n_groups
        Number of noise groups.
    b, level
        ``(n,)`` the column that the block scales and the index of each
        observation's level in ``f(z)``; None without a block.
    block
        The nonlinear block, or None.
    W
        ``(n, r)`` columns whose coefficients ``u(z)`` the block also sets
        (:meth:`NonlinearBlock.shift`); None: none.
    """

    y: np.ndarray
    X: np.ndarray
    group: np.ndarray
    n_groups: int
    b: np.ndarray | None = None
    level: np.ndarray | None = None
    block: NonlinearBlock | None = None
    W: np.ndarray | None = None
    _stats: _Sufficient = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        n = self.y.shape[0]
        if self.X.shape[0] != n or self.group.shape != (n,):
            raise ValueError("y, X and group must describe the same observations")
        if (self.block is None) != (self.b is None) or (self.b is None) != (self.level is None):
            raise ValueError("b, level and block go together")
        if self.W is not None and (self.block is None or self.W.shape[0] != n):
            raise ValueError("W needs a block and one row per observation")
        object.__setattr__(self, "_stats", _Sufficient.of(self))

    @property
    def n_linear(self) -> int:
        """Number of linear coefficients ``k``."""
        return int(self.X.shape[1])

    @property
    def n_block(self) -> int:
        """Length of ``z`` (0 without a block)."""
        return 0 if self.block is None else int(self.block.ndim)

    @property
    def ndim(self) -> int:
        """Length of ``theta``."""
        return self.n_linear + self.n_block + self.n_groups

    def residual(self, theta: np.ndarray) -> np.ndarray:
        """``(n,)`` observations less the model's prediction at ``theta`` (``nan`` outside the block's support)."""
        theta = np.asarray(theta, dtype=float)
        p, d = self.n_linear, self.n_block
        fit = self.X @ theta[:p]
        if self.block is not None:
            z = theta[None, p : p + d]
            fit = fit + self.b * self.block.evaluate(z)[0][0][self.level]
            if self.W is not None:
                fit = fit + self.W @ self.block.shift(z)[0]
        return self.y - fit

    def __call__(self, theta: np.ndarray) -> float:
        theta = np.asarray(theta, dtype=float)
        p, d = self.n_linear, self.n_block
        k, z, log_sigma = theta[:p], theta[p : p + d], theta[p + d :]
        if np.any(k <= 0):
            return -np.inf
        fit = self.X @ k
        prior = 0.0
        if self.block is not None:
            f, prior = self.block.evaluate(z[None])
            f, prior = f[0], float(prior[0])
            if not np.all(np.isfinite(f)) or not np.isfinite(prior):
                return -np.inf
            fit = fit + self.b * f[self.level]
            if self.W is not None:
                fit = fit + self.W @ self.block.shift(z[None])[0]
        ssr = np.bincount(self.group, weights=(self.y - fit) ** 2, minlength=self.n_groups)
        counts = self._stats.counts
        return float(np.sum(-counts * log_sigma - 0.5 * ssr * np.exp(-2.0 * log_sigma))) + prior


@dataclass(frozen=True)
class _Sufficient:
    """Per-group sums of a :class:`ConditionallyLinear` model: X'X, X'y, y'y and their terms in ``V = [B, W]``.

    ``B`` spreads the block's column over its levels (row i has ``b_i`` in
    column ``level_i``), so that ``B f + W u = V v`` with ``v = [f, u]``.
    """

    counts: np.ndarray
    XtX: np.ndarray
    Xty: np.ndarray
    yty: np.ndarray
    XtV: np.ndarray
    ytV: np.ndarray
    VtV: np.ndarray

    @classmethod
    def of(cls, model: ConditionallyLinear) -> _Sufficient:
        G, X, y = model.n_groups, model.X, model.y
        rows = [model.group == g for g in range(G)]
        m = 0 if model.block is None else int(model.level.max(initial=-1)) + 1
        B = np.zeros((y.size, m))
        if m:
            B[np.arange(y.size), model.level] = model.b
        V = B if model.W is None else np.hstack([B, model.W])
        return cls(
            counts=np.array([r.sum() for r in rows], dtype=float),
            XtX=np.stack([X[r].T @ X[r] for r in rows]),
            Xty=np.stack([X[r].T @ y[r] for r in rows]),
            yty=np.array([y[r] @ y[r] for r in rows]),
            XtV=np.stack([X[r].T @ V[r] for r in rows]),
            ytV=np.stack([y[r] @ V[r] for r in rows]),
            VtV=np.stack([V[r].T @ V[r] for r in rows]),
        )

    def precision(self, sigma2: np.ndarray) -> np.ndarray:
        """``(c, p, p)`` precision of ``k`` given the variances ``(c, G)``."""
        return np.einsum("cg,gij->cij", 1.0 / sigma2, self.XtX)

    def Xtr(self, v: np.ndarray) -> np.ndarray:
        """``(c, G, p)`` ``X_g'(y_g - V_g v)`` at the block's values ``v = [f, u]`` ``(c, m + r)``."""
        return self.Xty[None] - np.einsum("gpm,cm->cgp", self.XtV, v)

    def rhs(self, v: np.ndarray, sigma2: np.ndarray) -> np.ndarray:
        """``(c, p)`` ``sum_g X_g'(y_g - V_g v) / sigma_g^2``."""
        return np.einsum("cgp,cg->cp", self.Xtr(v), 1.0 / sigma2)

    def rtr(self, v: np.ndarray) -> np.ndarray:
        """``(c, G)`` ``|y_g - V_g v|^2``."""
        return self.yty[None] - 2.0 * v @ self.ytV.T + np.einsum("cm,gmn,cn->cg", v, self.VtV, v)

    def ssr(self, k: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(c, G)`` residual sums of squares at ``k`` ``(c, p)`` and block values ``v`` ``(c, m + r)``."""
        quadratic = np.einsum("ci,gij,cj->cg", k, self.XtX, k)
        return np.maximum(self.rtr(v) - 2.0 * np.einsum("cgp,cp->cg", self.Xtr(v), k) + quadratic, 0.0)


class _Collapsed:
    """Log posterior of ``z`` given the variances, with ``k`` integrated out, for a batch of points."""

    def __init__(self, model: ConditionallyLinear) -> None:
        self.model = model
        self.stats = model._stats

    def __call__(self, z: np.ndarray, sigma2: np.ndarray, covariance: np.ndarray) -> np.ndarray:
        """``(c,)`` values at ``z`` ``(c, d)``, variances ``(c|1, G)`` and k's conditional covariance ``(c|1, p, p)``."""
        block = self.model.block
        f, log_prior = block.evaluate(z)
        u = block.shift(z)
        bad = ~np.all(np.isfinite(f), axis=1) | ~np.isfinite(log_prior)
        v = np.concatenate([np.where(bad[:, None], 0.0, f), u], axis=1)
        value = -0.5 * np.sum(self.stats.rtr(v) / sigma2, axis=1)
        if self.model.n_linear:
            rhs = self.stats.rhs(v, np.broadcast_to(sigma2, (f.shape[0], sigma2.shape[-1])))
            value = value + 0.5 * np.einsum("cp,cp->c", rhs, (covariance @ rhs[..., None])[..., 0])
        return np.where(bad, -np.inf, value + np.where(bad, 0.0, log_prior))


@dataclass(frozen=True)
class _Proposal:
    """Per-chain Student-t proposals over the adapted coordinates: centres ``(c, d)`` and factors ``(c, d, d)``."""

    center: np.ndarray
    chol: np.ndarray

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        c, d = self.center.shape
        t = rng.standard_normal((c, d)) / np.sqrt(rng.chisquare(T_DOF, size=(c, 1)) / T_DOF)
        return self.center + T_INFLATION * (self.chol @ t[..., None])[..., 0]

    def log_q(self, z: np.ndarray) -> np.ndarray:
        u = np.linalg.solve(T_INFLATION * self.chol, (z - self.center)[..., None])[..., 0]
        return -0.5 * (T_DOF + z.shape[1]) * np.log1p(np.sum(u**2, axis=1) / T_DOF)

    def refit(self, history: np.ndarray) -> _Proposal:
        """The proposal refitted to the mean and covariance of the draws ``(steps, c, d)`` of all chains; kept if degenerate.

        Pooling the chains gives a covariance from several times more draws than
        one chain's, which matters for the skewed, weakly identified directions.
        """
        steps, c, d = history.shape
        if steps * c < 10 * d:
            return self
        pooled = history.reshape(-1, d)
        try:
            chol = np.linalg.cholesky(np.cov(pooled, rowvar=False))
        except np.linalg.LinAlgError:
            return self
        return _Proposal(center=np.tile(pooled.mean(axis=0), (c, 1)), chol=np.tile(chol, (c, 1, 1)))


@dataclass(frozen=True)
class GibbsSampler:
    """Partially collapsed Gibbs sampler of :class:`ConditionallyLinear` models.

    Honours the sampler protocol: ``sample(target, start, scale, rng)``; the
    target must be a :class:`ConditionallyLinear` model, whose structure it uses.

    Parameters
    ----------
    n_chains
        Number of chains, run together and each started from its own dispersed point.
    n_tune
        Iterations discarded at the start of each chain.
    n_draws
        Iterations kept per chain.
    """

    n_chains: int = 4
    n_tune: int = 200
    n_draws: int = 1000

    def sample(self, target: ConditionallyLinear, start: np.ndarray, scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draws ``(chain, draw, ndim)`` of ``theta = [k, z, log sigma]``.

        Parameters
        ----------
        target
            The model.
        start
            A parameter vector near the posterior mode (e.g. the closed-form
            estimate); the block's proposal is fitted around it and each chain
            starts from a dispersed point.
        scale
            Typical posterior sd of each parameter; only the block's entries are
            used, to scale the search for the mode of its collapsed posterior.
        rng
            Source of all randomness.
        """
        if not isinstance(target, ConditionallyLinear):
            raise TypeError(f"GibbsSampler samples ConditionallyLinear models, got {type(target).__name__}")
        model, stats = target, target._stats
        p, d, G, C = model.n_linear, model.n_block, model.n_groups, self.n_chains
        start = np.asarray(start, dtype=float)
        scale = np.broadcast_to(np.asarray(scale, dtype=float), start.shape)
        k = np.broadcast_to(start[:p], (C, p)).copy()
        z = np.broadcast_to(start[p : p + d], (C, d)).copy()
        sigma2 = np.exp(2.0 * start[p + d :])[None] * np.exp(rng.normal(0.0, START_SPREAD, (C, G)))
        collapsed = _Collapsed(model) if d else None
        if d:
            adapted = model.block.n_adapted
            proposal = _laplace(collapsed, start[p : p + d], scale[p : p + d], np.exp(2.0 * start[p + d :]), adapted, C)
            z[:, :adapted] = _finite_start(proposal, collapsed, z, sigma2, _covariance(stats, sigma2), rng)
            trailing = _GaussianPrior(model.block.prior_mean, model.block.prior_cov) if d > adapted else None
        refits = {int(self.n_tune * fraction) for fraction in REFITS} - {0}
        history = []
        draws = np.empty((C, self.n_draws, model.ndim))
        for step in range(self.n_tune + self.n_draws):
            covariance = _covariance(stats, sigma2)
            if d:
                if step in refits:
                    proposal = proposal.refit(np.array(history[len(history) // 2 :]))
                z = _block_step(collapsed, proposal, trailing, z, sigma2, covariance, rng)
                history.append(z[:, : proposal.center.shape[1]])
                v = np.concatenate([model.block.evaluate(z)[0], model.block.shift(z)], axis=1)
            else:
                v = np.zeros((C, 0))
            if p:
                mean = (covariance @ stats.rhs(v, sigma2)[..., None])[..., 0]
                k = _positive_gaussian(mean, covariance, k, rng)
            sigma2 = 0.5 * stats.ssr(k, v) / rng.gamma(0.5 * stats.counts, size=(C, G))
            if step >= self.n_tune:
                draws[:, step - self.n_tune] = np.concatenate([k, z, 0.5 * np.log(sigma2)], axis=1)
        return draws


def _covariance(stats: _Sufficient, sigma2: np.ndarray) -> np.ndarray:
    if not stats.XtX.shape[1]:
        return np.zeros((sigma2.shape[0], 0, 0))
    return np.linalg.inv(stats.precision(sigma2))


@dataclass(frozen=True)
class _GaussianPrior:
    mean: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "chol", np.linalg.cholesky(self.cov))

    def draw(self, c: int, rng: np.random.Generator) -> np.ndarray:
        return self.mean + rng.standard_normal((c, self.mean.size)) @ self.chol.T

    def log_density(self, x: np.ndarray) -> np.ndarray:
        u = np.linalg.solve(self.chol, (x - self.mean).T).T
        return -0.5 * np.sum(u**2, axis=1)


def _block_step(collapsed, proposal, trailing, z, sigma2, covariance, rng) -> np.ndarray:
    """One update of the block in every chain: independence, random-walk, then trailing-prior steps."""
    a = proposal.center.shape[1]
    current = collapsed(z, sigma2, covariance)
    candidate = z.copy()
    candidate[:, :a] = proposal.draw(rng)
    value = collapsed(candidate, sigma2, covariance)
    log_ratio = value - current + proposal.log_q(z[:, :a]) - proposal.log_q(candidate[:, :a])
    z, current = _accept(z, current, candidate, value, log_ratio, rng)
    step = 2.38 / np.sqrt(a)
    for _ in range(RANDOM_WALK_STEPS):
        candidate = z.copy()
        candidate[:, :a] += step * (proposal.chol @ rng.standard_normal((z.shape[0], a, 1)))[..., 0]
        value = collapsed(candidate, sigma2, covariance)
        z, current = _accept(z, current, candidate, value, value - current, rng)
    if trailing is not None:
        candidate = z.copy()
        candidate[:, a:] = trailing.draw(z.shape[0], rng)
        value = collapsed(candidate, sigma2, covariance)
        # Proposed from its prior, so only the likelihood ratio counts.
        log_ratio = value - trailing.log_density(candidate[:, a:]) - current + trailing.log_density(z[:, a:])
        z, current = _accept(z, current, candidate, value, log_ratio, rng)
    return z


def _accept(z, current, candidate, value, log_ratio, rng):
    accept = np.log(rng.uniform(size=z.shape[0])) < log_ratio
    return np.where(accept[:, None], candidate, z), np.where(accept, value, current)


def _finite_start(proposal: _Proposal, collapsed, z, sigma2, covariance, rng, tries: int = START_TRIES) -> np.ndarray:
    """Each chain's adapted coordinates drawn from the proposal, redrawn until the posterior is finite there.

    A chain whose draws keep missing the support (a Laplace fit gone wide on a
    posterior that is far from Gaussian) starts at the caller's start ``z``
    itself; the proposal refits of the tuning phase then take over.
    """
    a = proposal.center.shape[1]
    start = z.copy()
    pending = np.ones(z.shape[0], dtype=bool)
    for _ in range(tries):
        start[pending, :a] = proposal.draw(rng)[pending]
        pending &= ~np.isfinite(collapsed(start, sigma2, covariance))
        if not pending.any():
            return start[:, :a]
    start[pending] = z[pending]
    if not np.all(np.isfinite(collapsed(start, sigma2, covariance))):
        raise ValueError("the posterior is not finite at the start: start the chains inside the support")
    return start[:, :a]


def _laplace(collapsed: _Collapsed, z0: np.ndarray, scale: np.ndarray, sigma2: np.ndarray, adapted: int, chains: int) -> _Proposal:
    """Student-t proposal for the adapted coordinates at the mode of the collapsed posterior, with its Laplace covariance.

    The mode and covariance come from :func:`~bayescal.sampling.independence.laplace`
    (Newton steps on batched central differences).  Where the density is not
    finite near the start (its support's edge), the proposal starts as
    ``scale`` around the start and the tuning refits take over.
    """
    from bayescal.sampling.independence import laplace

    sigma2 = sigma2[None]
    covariance = _covariance(collapsed.stats, sigma2)
    unit = np.where(scale[:adapted] > 0, scale[:adapted], 1.0)

    def log_prob(x: np.ndarray) -> np.ndarray:
        z = np.broadcast_to(z0, (x.shape[0], z0.size)).copy()
        z[:, :adapted] = x
        return collapsed(z, sigma2, covariance)

    log_prob.vectorized = True
    try:
        center, cov = laplace(log_prob, z0[:adapted], unit)
        chol = np.linalg.cholesky(cov)
    except (ValueError, np.linalg.LinAlgError):
        center, chol = z0[:adapted], np.diag(unit)
    return _Proposal(center=np.tile(center, (chains, 1)), chol=np.tile(chol, (chains, 1, 1)))


def _positive_gaussian(mean: np.ndarray, covariance: np.ndarray, current: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draws of ``N(mean, covariance)`` restricted to positive values, one per chain (rows).

    Rejection is exact and almost always succeeds at once (compliances are many
    sd from zero); for a chain where it keeps failing, one sweep of
    coordinate-wise truncated normal draws from ``current`` (itself positive)
    keeps the chain valid.
    """
    chol = np.linalg.cholesky(covariance)
    out = np.array(current, dtype=float)
    pending = np.ones(mean.shape[0], dtype=bool)
    for _ in range(64):
        x = mean + (chol @ rng.standard_normal(mean.shape)[..., None])[..., 0]
        ok = pending & np.all(x > 0, axis=1)
        out[ok] = x[ok]
        pending &= ~ok
        if not pending.any():
            return out
    from scipy import stats

    for chain in np.flatnonzero(pending):
        precision = np.linalg.inv(covariance[chain])
        x = out[chain]
        for j in range(x.size):
            sd = 1.0 / np.sqrt(precision[j, j])
            others = precision[j] @ (x - mean[chain]) - precision[j, j] * (x[j] - mean[chain, j])
            loc = mean[chain, j] - others / precision[j, j]
            x[j] = stats.truncnorm.rvs(-loc / sd, np.inf, loc=loc, scale=sd, random_state=rng)
    return out
