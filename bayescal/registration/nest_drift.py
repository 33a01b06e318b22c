"""The tracker's frame in time, measured from readings of fixed reference nests, and removed from a campaign.

The frame moves a point ``p`` to ``p + T(t) + Ω(t) × (p - c)`` (``c`` the tracker): six
functions of time, a translation ``T`` (m) and a small rotation ``Ω`` (rad) about the
tracker.  The evidence is fixed points read at several times: reference nests, and a campaign's
repeat groups (:mod:`bayescal.registration.repeats`), both of unknown position.

*Form in time: a random walk.*  Each of the six is a Wiener process, of diffusion ``q``
(m²/s) for the translation and ``q / L²`` for the rotation (``L`` the nests' rms distance
from the tracker, so that both move a nest alike).  A tracker's stand follows the hall's temperature, which no low-order
polynomial follows over a shift (the independent generator plants a steady trend plus a
30 min cycle); the random walk assumes only that the frame moves continuously.  Its
posterior mean is the piecewise-linear interpolation between the nests' readings, and its
variance grows away from them as a Brownian bridge, so a reading far from any nest reading
is corrected with the uncertainty it has.  ``q`` is the maximum of the marginal likelihood on
:data:`DIFFUSION_GRID`.  A steady rate (flat prior) added to the walk was tried and left out:
the walk then had no trend to explain, its marginal likelihood chose q of 10⁻²⁰-10⁻¹⁴ m²/s on
the independent generator (its 30 min cycle of 20 μm went for noise) and 17 % of the
deflections' drift coordinates fell within 3 sd (ten Table III campaigns, seeds 0-9); the walk
alone takes the trend into q and covers the cycle.

*Unknowns*: the frame at every nest reading's time and each nest's position (a nuisance
with a flat prior; a repeat group is a nest).  The gauge is the frame at the first nest reading: only the frame's
changes are seen, and a constant offset is a registration's, not a drift's.

:func:`fit_nest_drift` returns a :class:`NestDrift`; :meth:`NestDrift.remove` takes its mean out
of a campaign's readings at their times and adds its variance to each deflection;
:meth:`NestDrift.removed_draws` takes out draws of it, over which a calibration is integrated
(:func:`~bayescal.inference.mixture.fit_integrated`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import linalg

from bayescal.cell.campaign import Campaign
from bayescal.cell.nests import Nests
from bayescal.cell.tracker import TrackerNoise
from bayescal.threads import one_blas_thread
from bayescal.units import MM

__all__ = ["NestDrift", "fit_nest_drift", "DIFFUSION_GRID", "motion_matrix", "removed_drift_sentence"]

DIFFUSION_GRID = 10.0 ** np.arange(-22.0, -6.0 + 1e-9, 0.25)
"""Candidate diffusions q (m²/s), a quarter decade apart: from a frame that wanders 0.6 nm in an
hour (as good as fixed) to one that wanders 1 mm every second (no tracker on a stand); the chosen
ones were 10⁻¹² to 1.8·10⁻¹¹ on the twin's and the independent generator's drifts (400 campaigns)."""


def motion_matrix(points: np.ndarray, tracker: np.ndarray) -> np.ndarray:
    """(k, 3, 6) how a point (k, 3) m moves per unit translation (m) and rotation about ``tracker`` (rad)."""
    lever = np.asarray(points, dtype=float) - tracker
    cross = np.zeros((len(lever), 3, 3))
    # Ω × lever = -lever × Ω: the cross-product matrix of -lever
    cross[:, 0, 1], cross[:, 0, 2] = lever[:, 2], -lever[:, 1]
    cross[:, 1, 0], cross[:, 1, 2] = -lever[:, 2], lever[:, 0]
    cross[:, 2, 0], cross[:, 2, 1] = lever[:, 1], -lever[:, 0]
    return np.concatenate([np.broadcast_to(np.eye(3), cross.shape), cross], axis=2)


@dataclass(frozen=True)
class _System:
    """The posterior's pieces that do not depend on q: nest readings placed on knots, and the nests' positions
    (3 each, flat prior) as nuisances."""

    knots: np.ndarray  # (n,) s
    scale: np.ndarray  # (6,) prior variance factor per component: 1 (translation), 1/L² (rotation)
    obs_dd: np.ndarray  # (n-1, 6, 6) W-weighted M^T M per free knot
    obs_dx: np.ndarray  # (6(n-1), 3K)
    obs_xx: np.ndarray  # (3K, 3K)
    b: np.ndarray  # (6(n-1) + 3K,)
    yy: float


def _system(nests: Nests, tracker: TrackerNoise) -> _System:
    knots, knot = np.unique(nests.times, return_inverse=True)
    names, nest = np.unique(nests.name, return_inverse=True)
    n, k = len(knots), len(names)
    weight = 1.0 / tracker.sigma(nests.position) ** 2
    motion = motion_matrix(nests.position, tracker.position)
    # each reading's nuisance columns: its nest's position
    nuisance = np.zeros((len(nests), 3, 3 * k))
    nuisance[np.arange(len(nests))[:, None], np.arange(3), 3 * nest[:, None] + np.arange(3)] = 1.0
    free = knot > 0  # the frame at the first knot is the gauge
    obs_dd = np.zeros((n, 6, 6))
    np.add.at(obs_dd, knot[free], weight[free, None, None] * np.einsum("kai,kaj->kij", motion[free], motion[free]))
    obs_dx = np.zeros((n, 6, 3 * k))
    np.add.at(obs_dx, knot[free], weight[free, None, None] * np.einsum("kai,kaj->kij", motion[free], nuisance[free]))
    b_d = np.zeros((n, 6))
    np.add.at(b_d, knot[free], weight[free, None] * np.einsum("kai,ka->ki", motion[free], nests.position[free]))
    obs_xx = np.einsum("k,kai,kaj->ij", weight, nuisance, nuisance)
    b_x = np.einsum("k,kai,ka->i", weight, nuisance, nests.position)
    length_sq = float(np.mean(np.sum((nests.position - tracker.position) ** 2, axis=1)))
    return _System(
        knots, np.repeat([1.0, 1.0 / length_sq], 3), obs_dd[1:], obs_dx[1:].reshape(6 * (n - 1), 3 * k),
        obs_xx, np.concatenate([b_d[1:].ravel(), b_x]), float(np.sum(weight * np.sum(nests.position**2, axis=1))),
    )


def _banded(system: _System, q: float) -> np.ndarray:
    """The frame's posterior precision at the free knots, lower banded form (12, 6(n-1))."""
    interval = np.diff(system.knots)
    inverse = 1.0 / (q * system.scale)  # (6,) per unit time
    to_next = np.append(1.0 / interval[1:], 0.0)  # the last knot has no later one
    diagonal = np.einsum("i,c->ic", 1.0 / interval + to_next, inverse)
    m = len(interval)
    ab = np.zeros((12, 6 * m))
    for r in range(6):
        for c in range(r + 1):
            ab[r - c, np.arange(m) * 6 + c] = system.obs_dd[:, r, c]
    ab[0] += diagonal.ravel()
    # between knot i and i+1 the same component: offset 6 in the band
    ab[6, : 6 * (m - 1)] = -np.einsum("i,c->ic", to_next[:-1], inverse).ravel()
    return ab


def _solve(system: _System, q: float):
    """Posterior mean (free knots, nests), log marginal likelihood up to a constant, and the factors."""
    chol = linalg.cholesky_banded(_banded(system, q), lower=True)
    free = system.obs_dd.shape[0] * 6
    t_inv_c = linalg.cho_solve_banded((chol, True), system.obs_dx)
    schur = system.obs_xx - system.obs_dx.T @ t_inv_c
    b_d, b_x = system.b[:free], system.b[free:]
    t_inv_b = linalg.cho_solve_banded((chol, True), b_d)
    x = np.linalg.solve(schur, b_x - system.obs_dx.T @ t_inv_b)
    d = t_inv_b - t_inv_c @ x
    quadratic = system.yy - b_d @ d - b_x @ x
    log_det = 2.0 * np.sum(np.log(chol[0])) + np.linalg.slogdet(schur)[1]
    prior_log_det = -free * np.log(q)  # the q-dependent part of the random walk's precision determinant
    return d, x, -0.5 * quadratic - 0.5 * log_det + 0.5 * prior_log_det, chol, t_inv_c, schur


@dataclass(frozen=True)
class NestDrift:
    """The tracker's frame in time, estimated from nest readings.

    Attributes
    ----------
    knots : numpy.ndarray
        (n,) times of the nest readings, s; the frame is zero at the first.
    mean : numpy.ndarray
        (n, 6) posterior mean of the frame at each knot: translation (m), rotation (rad).
    cov : numpy.ndarray
        (n, 6, n, 6) its posterior covariance.
    diffusion : float
        The random walk's diffusion q, m²/s (rotation q / L²).
    scale : numpy.ndarray
        (6,) each component's diffusion over q.
    tracker : numpy.ndarray
        (3,) the tracker's position, m.
    n_nests, n_readings : int
        Reference nests and their readings.
    n_groups, n_group_readings : int
        Repeat groups (:mod:`bayescal.registration.repeats`) and their readings.
    """

    knots: np.ndarray
    mean: np.ndarray
    cov: np.ndarray
    diffusion: float
    scale: np.ndarray
    tracker: np.ndarray
    n_nests: int
    n_readings: int
    n_groups: int = 0
    n_group_readings: int = 0

    def _place(self, times: np.ndarray):
        """For each time (k,): the knots either side (k, 2), their weights (k, 2), the Brownian bridge's variance factor
        (s), and the stretch of the walk each lies on (between two knots or beyond one end)."""
        t = np.asarray(times, dtype=float)
        n = len(self.knots)
        upper = np.clip(np.searchsorted(self.knots, t), 1, n - 1)
        lower = upper - 1
        a, b = self.knots[lower], self.knots[upper]
        inside = (t >= a) & (t <= b)
        w_b = np.where(inside, (t - a) / (b - a), (t > b).astype(float))
        bridge = np.where(inside, (t - a) * (b - t) / (b - a), np.where(t < a, a - t, t - b))
        knots = np.stack([lower, upper], axis=1)
        weights = np.stack([1.0 - w_b, w_b], axis=1)
        return knots, weights, bridge, np.searchsorted(self.knots, t, "right")

    def frame(self, times: np.ndarray) -> np.ndarray:
        """(k, 6) posterior mean of the frame at ``times`` (k,) s."""
        knots, weights, _, _ = self._place(times)
        return np.einsum("ku,kuj->kj", weights, self.mean[knots])

    def motion(self, points: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(k, 3) mean motion (m) of readings ``points`` (k, 3) taken at ``times`` (k,), and (k, 3, 3) its covariance (m²)."""
        knots, weights, bridge, _ = self._place(times)
        m = motion_matrix(points, self.tracker)
        cov = self._knots_cov(knots, weights[:, :, None, None] * m[:, None])
        cov += np.einsum("kai,i,kbi,k->kab", m, self.diffusion * self.scale, m, bridge)
        return np.einsum("kij,kj->ki", m, self.frame(times)), cov

    def _knots_cov(self, knots: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """(k, 3, 3) covariance of Σ_u weights[:, u] @ frame(knots[:, u]); ``knots`` (k, u), ``weights`` (k, u, 3, 6)."""
        blocks = self.cov[knots[:, :, None], :, knots[:, None, :], :]  # (k, u, v, 6, 6)
        return np.einsum("kuai,kuvij,kvbj->kab", weights, blocks, weights)

    def deflection(self, campaign: Campaign) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) the drift in each row's deflection (m), and (N, 3, 3) its covariance (m²)."""
        return self.change(campaign.p0, campaign.p1, campaign.times)

    def change(self, p0: np.ndarray, p1: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) the drift between readings ``p0`` and ``p1`` (N, 3) m taken at ``times`` (N, 2) s, and (N, 3, 3)
        its covariance (m²); zero for rows without times (poses to predict)."""
        timed = np.all(np.isfinite(times), axis=1)
        # a row without times is read at no time: its change is zero at the gauge's
        t0, t1 = (np.where(timed, times[:, k], self.knots[0]) for k in (0, 1))
        m0, m1 = motion_matrix(p0, self.tracker), motion_matrix(p1, self.tracker)
        mean = np.einsum("kij,kj->ki", m1, self.frame(t1)) - np.einsum("kij,kj->ki", m0, self.frame(t0))
        knots0, weights0, v0, stretch0 = self._place(t0)
        knots1, weights1, v1, stretch1 = self._place(t1)
        weights = np.concatenate([weights1[:, :, None, None] * m1[:, None], -weights0[:, :, None, None] * m0[:, None]], axis=1)
        cov = self._knots_cov(np.concatenate([knots1, knots0], axis=1), weights)
        # Two readings on the same stretch of the walk share its bridge up to the earlier.
        inside = (stretch0 > 0) & (stretch0 < len(self.knots))
        a, b = self.knots[knots0[:, 0]], self.knots[knots0[:, 1]]
        shared = np.where(stretch0 != stretch1, 0.0, np.where(inside, (t0 - a) * (b - t1) / (b - a), np.minimum(v0, v1)))
        q = self.diffusion * self.scale
        cov += np.einsum("kai,i,kbi,k->kab", m1, q, m1, v1) + np.einsum("kai,i,kbi,k->kab", m0, q, m0, v0)
        cov -= np.einsum("kai,i,kbi,k->kab", m1, q, m0, shared) + np.einsum("kai,i,kbi,k->kab", m0, q, m1, shared)
        return mean, cov

    def draws(self, times: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
        """(count, k, 6) draws of the frame at ``times`` (k,) s from its posterior, jointly over the times: the knots'
        frames from their covariance, and between and beyond the knots the walk's own bridges (a Wiener path on the
        knots and the times, less its interpolation at the knots: a bridge independent of the knots and of every
        other stretch's)."""
        n, t = len(self.knots), np.asarray(times, dtype=float)
        free = self.cov[1:, :, 1:, :].reshape(6 * (n - 1), 6 * (n - 1))
        # a relative jitter: the covariance is the inverse of a positive definite precision, up to rounding; one BLAS
        # thread, as for the fit (the twin's 273 nest readings: 0.64 s of CPU with two contending threads, 0.08 s with one)
        with one_blas_thread():
            factor = np.linalg.cholesky(free + 1e-12 * np.diag(np.diag(free)) + np.diag(np.full(len(free), 1e-300)))
        place, weights, _, _ = self._place(t)
        grid, index = np.unique(np.concatenate([self.knots, t]), return_inverse=True)
        spacing = np.diff(grid, prepend=grid[0])[:, None] * self.diffusion * self.scale
        out = np.empty((count, len(t), 6))
        for k in range(count):
            knots = np.zeros((n, 6))
            knots[1:] = self.mean[1:] + (factor @ rng.normal(size=len(free))).reshape(n - 1, 6)
            path = np.cumsum(rng.normal(size=(len(grid), 6)) * np.sqrt(spacing), axis=0)
            bridge = path[index[n:]] - np.einsum("ku,kuj->kj", weights, path[index[:n]][place])
            out[k] = np.einsum("ku,kuj->kj", weights, knots[place]) + bridge
        return out

    def removed_draws(self, campaign: Campaign, rng: np.random.Generator, count: int) -> list[Campaign]:
        """``count`` copies of the campaign, each with one draw of the drift (:meth:`draws`, jointly over all its
        readings' times) taken out of both readings at their times, and no variance added: over the copies, the draws'
        spread is the drift's uncertainty, correlated from row to row as the walk's is.  Rows without times are read at
        no time, where the frame is the gauge's (zero)."""
        n = len(campaign)
        timed = np.all(np.isfinite(campaign.times), axis=1)
        t0, t1 = (np.where(timed, campaign.times[:, k], self.knots[0]) for k in (0, 1))
        m0, m1 = motion_matrix(campaign.p0, self.tracker), motion_matrix(campaign.p1, self.tracker)
        return [
            replace(campaign, p0=campaign.p0 - np.einsum("kij,kj->ki", m0, frame[:n]),
                    p1=campaign.p1 - np.einsum("kij,kj->ki", m1, frame[n:]))
            for frame in self.draws(np.concatenate([t0, t1]), rng, count)
        ]

    def remove(self, campaign: Campaign) -> Campaign:
        """The campaign with the drift's posterior mean taken out of both readings at their times, its deflections'
        variance added.

        The added variance per coordinate is the largest eigenvalue of each deflection's drift covariance: the
        likelihood's noise is the same on the three coordinates, and the drift's is not.  A variance per row cannot
        carry the drift's error, correlated from row to row: the compliances calibrated on this campaign undercover
        (docs/critique.md, *Drift*), which :meth:`removed_draws` avoids.  The critique's rows take it, and a calibration
        integrated over the draws takes its residuals and chi-square from it.
        """
        motion0, _ = self.motion(campaign.p0, campaign.times[:, 0])
        motion1, _ = self.motion(campaign.p1, campaign.times[:, 1])
        _, cov = self.deflection(campaign)
        added = np.linalg.eigvalsh(cov)[:, -1]
        if campaign.added_variance is not None:
            added = added + campaign.added_variance
        return replace(campaign, p0=campaign.p0 - motion0, p1=campaign.p1 - motion1, added_variance=added)

    def to_json(self, campaign: Campaign) -> dict:
        """What the nests and repeats show and what removing the drift changes in ``campaign``, in mm and μm."""
        mean, cov = self.deflection(campaign)
        motion0, _ = self.motion(campaign.p0, campaign.times[:, 0])
        sd = np.sqrt(np.linalg.eigvalsh(cov)[:, -1])
        kinds = [kind for kind, n in (("reference nests", self.n_nests), ("repeats", self.n_groups)) if n]
        return {
            "source": " and ".join(kinds),
            "nests": self.n_nests,
            "nest_readings": self.n_readings,
            "repeat_groups": self.n_groups,
            "repeat_readings": self.n_group_readings,
            "span_s": round(float(self.knots[-1] - self.knots[0]), 1),
            "diffusion_um2_per_s": float(self.diffusion / MM**2 * 1e6),
            "readings_moved_max_mm": round(float(np.linalg.norm(motion0, axis=1).max() / MM), 4),
            "deflection_removed_rms_um": round(float(np.sqrt(np.mean(np.sum(mean**2, axis=1)))) * 1e6, 2),
            "deflection_removed_max_um": round(float(np.linalg.norm(mean, axis=1).max()) * 1e6, 2),
            "deflection_sd_added_median_um": round(float(np.median(sd)) * 1e6, 2),
            "deflection_sd_added_max_um": round(float(sd.max()) * 1e6, 2),
        }


def removed_drift_sentence(drift: dict) -> str:
    """The drift measured and removed, in words: ``drift`` is :meth:`NestDrift.to_json`'s block (its evidence: reference
    nests, repeat groups or both), with ``draws_integrated`` when a calibration was integrated over that many draws."""
    evidence = [f"{n} {kind} ({readings} readings)" for n, kind, readings in
                ((drift["nests"], "reference nests", drift["nest_readings"]),
                 (drift["repeat_groups"], "repeat groups", drift["repeat_readings"])) if n]
    sd = f"{drift['deflection_sd_added_median_um']:.1f} μm sd in a deflection (median, at most {drift['deflection_sd_added_max_um']:.1f})"
    draws = drift.get("draws_integrated")
    uncertainty = (f"its uncertainty, {sd}, integrated over: one calibration per draw of the drift ({draws} draws), pooled"
                   if draws else f"its uncertainty adds {sd}".replace(" in a ", " to a "))
    return (
        f"drift from {' and '.join(evidence)} over {drift['span_s'] / 3600:.1f} h: "
        f"removed {drift['deflection_removed_rms_um']:.1f} μm rms (at most {drift['deflection_removed_max_um']:.1f} μm) from the "
        f"deflections, readings moved by up to {drift['readings_moved_max_mm']:.3f} mm; {uncertainty}"
    )


def _most_likely(system: _System) -> float:
    """The diffusion of :data:`DIFFUSION_GRID` of largest marginal likelihood: every fourth first, then the grid around
    the best of those (a fourth of the solves; several hundred knots take about 30 ms a solve)."""
    coarse = np.arange(0, len(DIFFUSION_GRID), 4)
    best = coarse[int(np.argmax([_solve(system, q)[2] for q in DIFFUSION_GRID[coarse]]))]
    fine = np.arange(max(best - 3, 0), min(best + 4, len(DIFFUSION_GRID)))
    return float(DIFFUSION_GRID[fine[int(np.argmax([_solve(system, q)[2] for q in DIFFUSION_GRID[fine]]))]])


def fit_nest_drift(nests: Nests, tracker: TrackerNoise) -> NestDrift:
    """The frame's random walk fitted to ``nests`` with the tracker's noise model (module documentation)."""
    # the solves are banded and small: BLAS's threads only contend (on 2 cores a fit of 225 knots and 90 nuisance
    # nests took 13 s with them, 2 s on one)
    with one_blas_thread():
        system = _system(nests, tracker)
        q = _most_likely(system)
        d, _, _, chol, t_inv_c, schur = _solve(system, q)
        free, n = len(d), len(system.knots)
        t_inv = linalg.cho_solve_banded((chol, True), np.eye(free))
        cov = np.zeros((n, 6, n, 6))
        cov[1:, :, 1:, :] = (t_inv + t_inv_c @ np.linalg.solve(schur, t_inv_c.T)).reshape(n - 1, 6, n - 1, 6)
    mean = np.concatenate([np.zeros(6), d]).reshape(n, 6)
    return NestDrift(system.knots, mean, cov, q, system.scale, np.asarray(tracker.position, float),
                     int(np.unique(nests.name).size), len(nests))
