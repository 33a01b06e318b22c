"""Gibbs samplers that exploit the linear-Gaussian structure of the deflection model.

Given the noise variances, the deflections are linear in the joint compliances
with Gaussian errors, so the compliances have a Gaussian conditional posterior
(truncated to positive values), and given the compliances each noise variance
has an inverse-gamma conditional.  Both are drawn exactly.

For the compensated model (:class:`~bayescal.inference.likelihood.CompensatedPosterior`)
the joint-2 stiffness ``C(q2) @ w`` with ``w = [K_theta2^0, K_c, s0 K_c]`` and
the compensator geometry enter nonlinearly.  They are updated by Metropolis
steps on their posterior with the other compliances integrated out (a
partially collapsed Gibbs sampler), which removes the strong correlation
between joints 2 and 3 that would otherwise slow the chain; the compliances
are then drawn from their conditional.  ``(K_theta2^0, log K_c, s0)`` move by
an independence proposal (a Student t fitted at the posterior mode) followed
by random-walk steps whose covariance is refitted during tuning; the geometry,
which the deflections barely inform, by an independence proposal from its prior.

All sums over equations are precomputed per noise group, so an iteration costs
the same whatever the number of equations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize, stats

from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.inference.likelihood import CompensatedPosterior, PerAnglePosterior, compensator_regressor, in_support

__all__ = ["GibbsSampler"]

_T_DOF = 5.0
"""Degrees of freedom of the independence proposal: heavy enough tails to cover the posterior's."""
_RANDOM_WALK_STEPS = 5
"""Random-walk Metropolis steps per sweep: cheap, since the collapsed target costs O(1) in the equations."""
_T_INFLATION = 1.2
"""Scale of the independence proposal relative to the Laplace covariance."""


@dataclass(frozen=True)
class GibbsSampler:
    """Gibbs sampler for the per-angle and the compensated deflection models.

    Parameters
    ----------
    n_chains
        Number of independent chains, each started from its own dispersed point.
    n_tune
        Iterations discarded at the start of each chain.
    n_draws
        Iterations kept per chain.
    """

    n_chains: int = 4
    n_tune: int = 200
    n_draws: int = 1000

    def sample_per_angle(self, posterior: PerAnglePosterior, rng: np.random.Generator) -> np.ndarray:
        """Draws ``(chain, draw, ndim)`` of ``[compliances, log sigma]`` of the per-angle model."""
        equations = posterior.equations
        gram = _GroupedGram(posterior.design, equations.y, equations.group, len(equations.group_names))
        k_hat = np.linalg.lstsq(posterior.design, equations.y, rcond=None)[0]
        k_hat = np.where(k_hat > 0, k_hat, np.abs(k_hat) + 1e-12)
        sigma2_hat = gram.ssr(k_hat) / np.maximum(gram.counts - posterior.n_linear / gram.n_groups, 1.0)
        chains = np.empty((self.n_chains, self.n_draws, posterior.n_linear + gram.n_groups))
        for chain in range(self.n_chains):
            sigma2 = sigma2_hat * np.exp(rng.normal(0.0, 0.5, gram.n_groups))
            k = k_hat
            for step in range(self.n_tune + self.n_draws):
                mean, chol = gram.conditional(sigma2)
                k = _positive_gaussian(mean, chol, k, rng)
                sigma2 = _inverse_gamma(gram.counts, gram.ssr(k), rng)
                if step >= self.n_tune:
                    chains[chain, step - self.n_tune] = np.concatenate([k, 0.5 * np.log(sigma2)])
        return chains

    def sample_compensated(self, posterior: CompensatedPosterior, start: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draws ``(chain, draw, ndim)`` in the parameter order of ``posterior``.

        Parameters
        ----------
        posterior
            The compensated model.
        start
            A parameter vector near the posterior mode (e.g. the closed-form
            estimate); it centres the first proposal, and each chain starts from
            a dispersed draw around it.
        rng
            Source of all randomness.

        Notes
        -----
        During tuning, each chain refits its Metropolis proposal three times to
        the mean and covariance of its own recent draws, so that the proposal
        follows the posterior even where the Laplace approximation is poor
        (a weakly identified ``K_c``); it is then frozen for the kept draws.
        """
        state = _CompensatedState(posterior)
        k0, stiffness0, _, log_sigma0 = posterior.split(np.asarray(start, dtype=float))
        sigma2_0 = np.exp(2.0 * log_sigma0)
        laplace = state.laplace(stiffness0, sigma2_0)
        refits = {self.n_tune * i // 4 for i in (1, 2, 3)} - {0}
        geometry_prior = posterior.geometry
        chains = np.empty((self.n_chains, self.n_draws, posterior.ndim))
        for chain in range(self.n_chains):
            proposal = laplace
            sigma2 = sigma2_0 * np.exp(rng.normal(0.0, 0.3, sigma2_0.size))
            factor = state.precision_factor(sigma2)
            spring = proposal.draw(rng)
            geometry = geometry_prior.mean if state.n_geometry else np.empty(0)
            while not np.isfinite(state.collapsed(np.concatenate([spring, geometry]), sigma2, factor)):
                spring = proposal.draw(rng)
            k = k0
            history = []
            for step in range(self.n_tune + self.n_draws):
                if step in refits:
                    proposal = proposal.refit(np.array(history[len(history) // 2 :]))
                factor = state.precision_factor(sigma2)

                def target(x, geometry=geometry, sigma2=sigma2, factor=factor):
                    return state.collapsed(np.concatenate([x, geometry]), sigma2, factor)

                spring, current = proposal.independence_step(spring, target(spring), target, rng)
                for _ in range(_RANDOM_WALK_STEPS):
                    spring, current = proposal.random_walk_step(spring, current, target, rng)
                if state.n_geometry:
                    geometry = state.geometry_step(spring, geometry, current, sigma2, factor, rng)
                history.append(spring)
                z = np.concatenate([spring, geometry])
                k2 = state.joint2(z)
                mean, chol = state.linear_conditional(k2, sigma2)
                k = _positive_gaussian(mean, chol, k, rng) if k.size else k
                sigma2 = _inverse_gamma(state.gram.counts, state.ssr(k, k2), rng)
                if step >= self.n_tune:
                    chains[chain, step - self.n_tune] = state.theta(k, z, sigma2)
        return chains


class _GroupedGram:
    """Per-noise-group sums X'X, X'y, y'y of a linear model."""

    def __init__(self, X: np.ndarray, y: np.ndarray, group: np.ndarray, n_groups: int) -> None:
        self.n_groups = n_groups
        self.counts = np.bincount(group, minlength=n_groups).astype(float)
        self.XtX = np.stack([X[group == g].T @ X[group == g] for g in range(n_groups)])
        self.Xty = np.stack([X[group == g].T @ y[group == g] for g in range(n_groups)])
        self.yty = np.array([y[group == g] @ y[group == g] for g in range(n_groups)])

    def conditional(self, sigma2: np.ndarray, Xty: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Mean and lower Cholesky factor of the precision of the coefficients given the variances."""
        precision = np.tensordot(1.0 / sigma2, self.XtX, axes=1)
        rhs = (self.Xty if Xty is None else Xty).T @ (1.0 / sigma2)
        chol = linalg.cholesky(precision, lower=True)
        return linalg.cho_solve((chol, True), rhs), chol

    def ssr(self, k: np.ndarray) -> np.ndarray:
        """Sum of squared residuals per group."""
        return np.maximum(self.yty - 2.0 * self.Xty @ k + np.einsum("i,gij,j->g", k, self.XtX, k), 0.0)


class _CompensatedState:
    """Precomputed sums and conditionals of the compensated model."""

    def __init__(self, posterior: CompensatedPosterior) -> None:
        self.posterior = posterior
        eq = posterior.equations
        X = eq.design[:, list(posterior.joints)]
        b = eq.design[:, COMPENSATED_JOINT]
        G, m = len(eq.group_names), eq.q2.size
        self.gram = _GroupedGram(X, eq.y, eq.group, G)
        # Joint 2's column spread over the angles: rows of E pick the equation's angle.
        E = np.zeros((eq.n, m))
        E[np.arange(eq.n), eq.angle] = b
        self.XtB = np.stack([X[eq.group == g].T @ E[eq.group == g] for g in range(G)])
        self.ytB = np.stack([eq.y[eq.group == g] @ E[eq.group == g] for g in range(G)])
        self.BtB = np.stack([(E[eq.group == g] ** 2).sum(axis=0) for g in range(G)])
        self.n_geometry = posterior.n_geometry

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``w = [K0, K_c, s0 K_c]`` and the geometry from ``z = [K0, log K_c, s0, geometry]``."""
        geometry = z[3:] if self.n_geometry else self.posterior.geometry.mean
        Kc = np.exp(z[1])
        return np.array([z[0], Kc, z[2] * Kc]), geometry

    def joint2(self, z: np.ndarray) -> np.ndarray:
        w, geometry = self.split(z)
        return 1.0 / (compensator_regressor(geometry, self.posterior.equations.q2) @ w)

    def _Xtr(self, k2: np.ndarray) -> np.ndarray:
        return self.gram.Xty - self.XtB @ k2

    def linear_conditional(self, k2: np.ndarray, sigma2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not self.posterior.joints:
            return np.empty(0), np.empty((0, 0))
        return self.gram.conditional(sigma2, self._Xtr(k2))

    def _rtr(self, k2: np.ndarray) -> np.ndarray:
        return self.gram.yty - 2.0 * self.ytB @ k2 + self.BtB @ k2**2

    def ssr(self, k: np.ndarray, k2: np.ndarray) -> np.ndarray:
        Xtr = self._Xtr(k2)
        fit = -2.0 * Xtr @ k + np.einsum("i,gij,j->g", k, self.gram.XtX, k) if k.size else 0.0
        return np.maximum(self._rtr(k2) + fit, 0.0)

    def precision_factor(self, sigma2: np.ndarray) -> np.ndarray | None:
        """Lower Cholesky factor of the compliances' precision given the variances (None without compliances)."""
        if not self.posterior.joints:
            return None
        return linalg.cholesky(np.tensordot(1.0 / sigma2, self.gram.XtX, axes=1), lower=True)

    def geometry_step(self, spring, geometry, current, sigma2, factor, rng) -> np.ndarray:
        """Independence Metropolis step for the geometry, proposed from its prior (so only the likelihood ratio counts).

        ``current`` is the collapsed log-posterior at ``(spring, geometry)``.
        """
        prior = self.posterior.geometry
        candidate = rng.multivariate_normal(prior.mean, prior.cov)
        new = self.collapsed(np.concatenate([spring, candidate]), sigma2, factor) - prior.log_density(candidate)
        old = current - prior.log_density(geometry)
        return candidate if np.log(rng.uniform()) < new - old else geometry

    def collapsed(self, z: np.ndarray, sigma2: np.ndarray, factor: np.ndarray | None = None) -> float:
        """Log-posterior of ``z = [K0, log K_c, s0, geometry]`` given the variances, compliances integrated out.

        K_c is moved on the log scale, where its posterior is far less skewed
        when the data determine it loosely; ``+ log K_c`` is the Jacobian of the
        flat prior on K_c.
        """
        w, geometry = self.split(z)
        if not in_support(np.array([w[0], w[1], z[2]]), geometry):
            return -np.inf
        total = compensator_regressor(geometry, self.posterior.equations.q2) @ w
        if np.any(total <= 0):
            return -np.inf
        k2 = 1.0 / total
        value = -0.5 * float(self._rtr(k2) @ (1.0 / sigma2))
        if self.posterior.joints:
            factor = self.precision_factor(sigma2) if factor is None else factor
            rhs = self._Xtr(k2).T @ (1.0 / sigma2)
            value += 0.5 * float(rhs @ linalg.cho_solve((factor, True), rhs, check_finite=False))
        return value + float(z[1]) + self.posterior.geometry.log_density(geometry)

    def theta(self, k: np.ndarray, z: np.ndarray, sigma2: np.ndarray) -> np.ndarray:
        stiffness = np.array([z[0], np.exp(z[1]), z[2]])
        return np.concatenate([k, stiffness, z[3:], 0.5 * np.log(sigma2)])

    def laplace(self, stiffness: np.ndarray, sigma2: np.ndarray) -> _Proposal:
        """Student-t proposal centred at the mode of the collapsed posterior, with its Laplace covariance."""
        z0 = np.array([stiffness[0], np.log(stiffness[1]), stiffness[2]], dtype=float)
        scale = np.array([0.01 * stiffness[0], 0.2, 0.05 * stiffness[2]])
        if self.n_geometry:
            z0 = np.concatenate([z0, self.posterior.geometry.mean])
            scale = np.concatenate([scale, np.sqrt(np.diag(self.posterior.geometry.cov))])

        def negative(x: np.ndarray) -> float:
            value = self.collapsed(z0 + scale * x, sigma2)
            return -value if np.isfinite(value) else 1e300

        best = optimize.minimize(negative, np.zeros(z0.size), method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-6, "maxiter": 4000})
        best = optimize.minimize(negative, best.x, method="BFGS")
        mode = best.x
        hessian = _hessian(negative, mode, 0.05)
        try:
            cov_x = np.linalg.inv(hessian)
            chol = np.linalg.cholesky(cov_x)
        except np.linalg.LinAlgError:
            chol = np.eye(z0.size)
        center = z0 + scale * mode
        cov = (scale[:, None] * chol) @ (scale[:, None] * chol).T
        return _Proposal(center=center[:3], chol=np.linalg.cholesky(cov[:3, :3]))


def _hessian(f, x: np.ndarray, step: float) -> np.ndarray:
    n = x.size
    H = np.empty((n, n))
    for i in range(n):
        for j in range(i, n):
            e_i, e_j = np.eye(n)[i] * step, np.eye(n)[j] * step
            H[i, j] = H[j, i] = (f(x + e_i + e_j) - f(x + e_i - e_j) - f(x - e_i + e_j) + f(x - e_i - e_j)) / (4 * step**2)
    return H


@dataclass(frozen=True)
class _Proposal:
    center: np.ndarray
    chol: np.ndarray

    def _log_q(self, z: np.ndarray) -> float:
        u = linalg.solve_triangular(self.chol * _T_INFLATION, z - self.center, lower=True)
        return float(-0.5 * (_T_DOF + z.size) * np.log1p(u @ u / _T_DOF))

    def refit(self, draws: np.ndarray) -> _Proposal:
        """A proposal with the mean and covariance of ``draws``; this one if they are too few or degenerate."""
        if draws.shape[0] < 5 * draws.shape[1]:
            return self
        try:
            chol = np.linalg.cholesky(np.cov(draws, rowvar=False))
        except np.linalg.LinAlgError:
            return self
        return _Proposal(center=draws.mean(axis=0), chol=chol)

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        t = rng.standard_normal(self.center.size) / np.sqrt(rng.chisquare(_T_DOF) / _T_DOF)
        return self.center + _T_INFLATION * self.chol @ t

    def independence_step(self, z: np.ndarray, current: float, log_target, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """One independence Metropolis step from ``z`` (log-target ``current``): the new point and its log-target."""
        candidate = self.draw(rng)
        value = log_target(candidate)
        log_ratio = value - current + self._log_q(z) - self._log_q(candidate)
        return (candidate, value) if np.log(rng.uniform()) < log_ratio else (z, current)

    def random_walk_step(self, z: np.ndarray, current: float, log_target, rng: np.random.Generator) -> tuple[np.ndarray, float]:
        """One random-walk Metropolis step, scaled by 2.38/sqrt(d) times the proposal's covariance factor."""
        candidate = z + 2.38 / np.sqrt(z.size) * self.chol @ rng.standard_normal(z.size)
        value = log_target(candidate)
        return (candidate, value) if np.log(rng.uniform()) < value - current else (z, current)


def _inverse_gamma(counts: np.ndarray, ssr: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Variances from their conditional under the Jeffreys prior: InvGamma(n/2, SSR/2)."""
    return 0.5 * ssr / rng.gamma(0.5 * counts)


def _positive_gaussian(mean: np.ndarray, chol: np.ndarray, current: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A draw of N(mean, (L L')^-1) restricted to positive values.

    Rejection is exact and almost always succeeds at once (compliances are many
    sd from zero); when it keeps failing, one sweep of coordinate-wise truncated
    normal draws from ``current`` (itself positive) keeps the chain valid.
    """
    for _ in range(64):
        x = mean + linalg.solve_triangular(chol.T, rng.standard_normal(mean.size), lower=False)
        if np.all(x > 0):
            return x
    precision = chol @ chol.T
    x = np.array(current, dtype=float)
    for j in range(x.size):
        sd = 1.0 / np.sqrt(precision[j, j])
        others = precision[j] @ (x - mean) - precision[j, j] * (x[j] - mean[j])
        loc = mean[j] - others / precision[j, j]
        x[j] = stats.truncnorm.rvs(-loc / sd, np.inf, loc=loc, scale=sd, random_state=rng)
    return x
