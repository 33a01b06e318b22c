"""Bayesian identification of the compensator geometry from laser-tracker arcs.

The closed-form fits of :mod:`bayescal.geometry.arcs` give point estimates; this
module gives the posterior of the same geometry under an explicit
measurement model, sampled with :class:`bayescal.sampling.ensemble.EnsembleSampler`
and summarised with :mod:`bayescal.sampling.summary`.

Measurement model (planar, in the tracker's (x, y); z is not used):

* P1 (known angles, eq 10): ``p_i = p2 + L·[cos(phi + κ q_i), sin(phi + κ q_i)] + e_i``
  with ``κ = ±1`` the arc's sense found by the closed-form fit (-1 on Table I)
  and ``e_i ~ N(0, σ_lever² I)``.
* Cylinder markers P0<k>, one of two models, with ``e_i ~ N(0, σ_cylinder² I)``
  (one σ shared by the cylinder markers):

  ``"concentric"`` (the paper's, eqs 20-29): each point lies on a circle of
  radius ``R_k`` about p0 at an unknown angle ``β_i``,
  ``p_i = p0 + R_k·[cos β_i, sin β_i] + e_i``.  Under a uniform prior on
  each ``β_i`` the angle integrates out: the point's density,
  ``exp(-(d - R)²/2σ²) I0e(d R/σ²) / (2π σ²)`` (``d = |p_i - p0|``, ``I0e``
  the exponentially scaled Bessel function), depends on ``d`` only.

  ``"rigid"``: the markers are fixed on the cylinder, whose axis runs from P0
  through P1, so each sits at a fixed polar offset ``(R_k, δ_k)`` from the
  cylinder's direction: ``p_i = p0 + R_k·[cos(θ_i + δ_k), sin(θ_i + δ_k)] + e_i``
  with ``θ_i`` the direction of ``P1(q_i) - p0``.  Stronger (the angles are
  no longer free) but right only if the markers are rigid on a cylinder that
  points at P1.

Priors (weakly informative, proper): each coordinate of p2 and p0
``N(0, (10 m)²)``; ``L`` and the radii uniform on (0, 10 m); ``phi`` (and
``δ_k``) uniform on a full turn centred on the closed-form value (the
likelihood is periodic); each σ log-uniform on [1 μm, 10 mm].

Sampling: the σ's are integrated out analytically, the injected sampler
(by default :class:`bayescal.sampling.independence.IndependenceSampler`)
samples the remaining geometry, and each σ is then drawn from its exact
conditional (a collapsed Gibbs step); see :class:`_Density`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from os import PathLike
from typing import Literal

import numpy as np
import pandas as pd
import xarray as xr

from bayescal.sampling import summary as posterior
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.errors import InputError
from bayescal.geometry.arcs import LEVER_MARKER, CompensatorGeometryModel, GeometryFit, MarkerPoints
from bayescal.jsonsafe import json_safe
from bayescal.geometry.layout import cylinder_direction, lever_angle, lever_points
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.sampling.independence import IndependenceSampler
from bayescal.sampling.protocol import Sampler
from bayescal.units import DEG, MM

__all__ = ["GeometryPriors", "GeometryPosteriorModel", "GeometryPosterior", "default_sampler", "emcee_sampler"]

CylinderModel = Literal["concentric", "rigid"]


@dataclass(frozen=True)
class GeometryPriors:
    """Bounds and scales of the weakly informative priors (SI).

    Attributes
    ----------
    position_sd
        Standard deviation (m) of the zero-mean normal prior on each coordinate of p2 and p0.
    length_max
        Upper bound (m) of the uniform priors on ``L`` and the marker radii.
    sigma_min, sigma_max
        Bounds (m) of the log-uniform prior on each marker group's noise σ.
    """

    position_sd: float = 10.0
    length_max: float = 10.0
    sigma_min: float = 1e-6
    sigma_max: float = 1e-2


@dataclass(frozen=True)
class GeometryPosterior:
    """Posterior of the compensator geometry.

    Attributes
    ----------
    tree
        ArviZ DataTree; group ``posterior`` holds ``L, a_x, a_y, p2_x, p2_y,
        p0_x, p0_y`` (mm), ``phi, alpha`` (deg), the cylinder radii ``R`` (mm,
        by marker), the noise ``sigma`` (mm, for the ``lever`` and the
        ``cylinder`` markers) and, for the rigid model, the angular offsets
        ``delta`` (deg, by marker).
    closed_form
        The closed-form fit used as the sampler's start.
    geometry
        ``CompensatorGeometry`` at the posterior mean (SI).
    residuals
        Residuals at the posterior mean in m, by marker, in the order of
        ``points.of(marker)``: vectors ``(n, 2)`` for P1 and for rigid
        cylinder markers, radial distances ``(n,)`` for concentric ones.
    residuals_rms
        Root mean square of each marker's residuals (vector lengths or radial
        distances), in m.
    convergence
        ``r_hat_max, ess_bulk_min, ess_tail_min, n_chains, n_draws`` (:meth:`diagnostics`).
    cylinder_model
        ``"concentric"`` or ``"rigid"``.
    """

    tree: xr.DataTree
    closed_form: GeometryFit
    geometry: CompensatorGeometry
    residuals: dict[str, np.ndarray]
    residuals_rms: dict[str, float]
    convergence: dict[str, float | int]
    cylinder_model: CylinderModel

    def summary(self) -> pd.DataFrame:
        """Mean, sd, ±3σ interval, R-hat and ESS of every posterior variable (mm, deg)."""
        return posterior.summarize(self.tree)

    def diagnostics(self) -> dict[str, float | int]:
        """Convergence of the sampler: ``r_hat_max, ess_bulk_min, ess_tail_min, n_chains, n_draws``."""
        return dict(self.convergence)

    def to_json(self) -> dict:
        """Every result in edge units (mm, deg), as ``bayescal geometry --json`` prints it: ``cylinder_model``,
        ``parameters``, ``diagnostics``, ``residuals_rms_mm``, ``closed_form``, ``arc_sense`` and ``frame_mirrored``."""
        closed = self.closed_form.summary()
        return json_safe({
            "cylinder_model": self.cylinder_model,
            "parameters": posterior.parameters_json(self.summary()),
            "diagnostics": self.diagnostics(),
            "residuals_rms_mm": {name: value / MM for name, value in self.residuals_rms.items()},
            "closed_form": {
                name: {"value": float(row["value"]), "unit": row["unit"]} for name, row in closed.iterrows() if not name.startswith("rms[")
            },
            "arc_sense": "clockwise" if self.closed_form.lever.sense < 0 else "counter-clockwise",
            "frame_mirrored": self.closed_form.mirrored,
        })

    def save(self, path: str | PathLike[str]) -> None:
        """Write the posterior DataTree to a NetCDF file."""
        posterior.save(self.tree, path)


def default_sampler(n_chains: int = 4, n_tune: int = 200, n_draws: int = 1000) -> IndependenceSampler:
    """The sampler used by default: independence Metropolis-Hastings with a Laplace Student-t proposal.

    The geometry posterior (σ integrated out) is a product of two nearly
    Gaussian blocks, each close to a Student t with as many degrees of
    freedom as its group has coordinates beyond its parameters (8 and 8 on
    Table I).  A multivariate t proposal with 4 degrees of freedom has tails
    at least as heavy as that product's in every direction, so the importance
    weights stay bounded; widened 1.4 times over the Laplace sd it accepted
    70 % of proposals on Table I and gave a bulk ESS of 0.41 to 0.50 per
    draw for every parameter (6 seeds, 4 chains of 1500 draws).  Each chain
    starts at a proposal, whose distribution is close to the posterior's, so
    200 discarded steps are ample.
    """
    return IndependenceSampler(n_chains=n_chains, n_tune=n_tune, n_draws=n_draws, dof=4.0, widen=1.4)


def emcee_sampler(n_chains: int = 4, n_tune: int = 1000, n_draws: int = 1000) -> EnsembleSampler:
    """emcee ensembles with differential-evolution and stretch moves (the default before the independence sampler).

    On Table I the integrated autocorrelation time of the geometry posterior
    is 60-90 steps with emcee's stretch move alone and 30-50 with its
    ``DEMove``, but ``DEMove`` alone steps by differences of the other
    walkers and so returns slowly from the posterior's heavy tails (in 1 of 6
    seeds a walker strayed 20 posterior sd away for hundreds of steps); an
    80/20 mixture keeps the speed and lets the scale-free stretch move bring
    strays back.  emcee's ``DESnookerMove`` is not used: on this posterior it
    gave L an sd of 0.020 mm where the exact (Student t) posterior has 0.035 mm.
    """
    import emcee

    moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.StretchMove(), 0.2)]
    return EnsembleSampler(n_chains=n_chains, n_tune=n_tune, n_draws=n_draws, moves=moves)


class GeometryPosteriorModel:
    """Bayesian model of the compensator geometry (see the module docstring).

    Parameters
    ----------
    cylinder_model
        ``"concentric"`` (the paper's model, default) or ``"rigid"``.
    sampler
        Any :class:`bayescal.sampling.protocol.Sampler`; default :func:`default_sampler`
        (:func:`emcee_sampler` gives emcee ensembles).
    priors
        Prior bounds and scales.
    """

    def __init__(
        self,
        cylinder_model: CylinderModel = "concentric",
        sampler: Sampler | None = None,
        priors: GeometryPriors | None = None,
    ) -> None:
        if cylinder_model not in ("concentric", "rigid"):
            raise ValueError(f"cylinder_model must be 'concentric' or 'rigid', got {cylinder_model!r}")
        self.cylinder_model: CylinderModel = cylinder_model
        self.sampler = sampler if sampler is not None else default_sampler()
        self.priors = priors if priors is not None else GeometryPriors()

    def fit(self, points: MarkerPoints, rng: np.random.Generator | int | None = 0) -> GeometryPosterior:
        """Sample the posterior of the geometry given marker points.

        Parameters
        ----------
        points
            Marker points (see :func:`bayescal.geometry.arcs.read_arc_points`); only x and y are used.
        rng
            Generator or seed; the same seed gives the same draws.
        """
        rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        if points.xyz.shape[1] == 3:
            tilt = CompensatorGeometryModel().fit(points).axis_tilt
            warnings.warn(
                f"{points.source or 'points'}: the posterior uses x and y only (the paper's planar model, tracker Z "
                f"along the joint-2 axis); the 3D closed-form fit puts the cylinder's axis {tilt / DEG:.2f} deg from Z",
                UserWarning,
                stacklevel=2,
            )
        planar = MarkerPoints.from_arrays(points.marker, points.q2, points.xyz[:, :2], line=points.line, source=points.source)
        closed_form = CompensatorGeometryModel().fit(planar)
        density = _Density(planar, closed_form, self.cylinder_model, self.priors)
        unknowns = 2 + density.n_offset
        if density.counts[1] <= unknowns:
            raise InputError(
                f"the cylinder markers give {density.counts[1]:.0f} informative coordinates for {unknowns} unknowns "
                "(p0 and each marker's offset), so their noise cannot be estimated: measure more angles or markers",
                source=points.source,
            )
        start = density.start()
        # The noise scale each group's residuals give at the closed form; outside the prior's range the
        # posterior would be ruled by the prior's bound, which signals wrong units rather than a result.
        noise = np.sqrt(density.sums_of_squares(start) / density.counts)
        outside = (noise < self.priors.sigma_min) | (noise > self.priors.sigma_max)
        if outside.any() or not np.isfinite(density(start)):
            worst = noise[np.argmax(outside)]
            raise InputError(
                f"the closed-form fit leaves a residual rms of {worst / MM:.3g} mm per coordinate, outside the noise prior's "
                f"{self.priors.sigma_min / MM:g} to {self.priors.sigma_max / MM:g} mm: are q2 in deg and x, y in mm?",
                source=points.source,
            )
        draws = self.sampler.sample(density, start, density.scale(start), rng)
        sigma = density.draw_sigma(draws, rng)
        return self._result(density, draws, sigma, closed_form, points)

    def _result(
        self, density: _Density, draws: np.ndarray, sigma: np.ndarray, closed_form: GeometryFit, points: MarkerPoints
    ) -> GeometryPosterior:
        flip = -1.0 if closed_form.mirrored else 1.0
        p = density.unpack(draws)
        a_x = p["p2"][..., 0] - p["p0"][..., 0]
        a_y = flip * (p["p2"][..., 1] - p["p0"][..., 1])
        phi = flip * p["phi"]
        out = {
            "L": p["L"] / MM,
            "a_x": a_x / MM,
            "a_y": a_y / MM,
            "phi": phi / DEG,
            "alpha": (phi - np.arctan2(a_y, a_x)) / DEG,
            "p2_x": p["p2"][..., 0] / MM,
            "p2_y": p["p2"][..., 1] / MM,
            "p0_x": p["p0"][..., 0] / MM,
            "p0_y": p["p0"][..., 1] / MM,
            "R": p["radius"] / MM,
            "sigma": sigma / MM,
        }
        units = {name: "deg" if name in ("phi", "alpha") else "mm" for name in out}
        dims = {"R": ["cylinder_marker"], "sigma": ["noise_group"], "x_mm": ["point"], "y_mm": ["point"], "q2_deg": ["point"]}
        coords = {
            "cylinder_marker": density.cylinder_names,
            "noise_group": ["lever", "cylinder"],
            "point": [f"{m} q2={q / DEG:g}" for m, q in zip(points.marker, points.q2)],
        }
        if self.cylinder_model == "rigid":
            out["delta"] = flip * p["delta"] / DEG
            units["delta"] = "deg"
            dims["delta"] = ["cylinder_marker"]
        observed = {"q2_deg": points.q2 / DEG, "x_mm": points.xyz[:, 0] / MM, "y_mm": points.xyz[:, 1] / MM}
        attrs = {
            "model": f"compensator geometry, {self.cylinder_model} cylinder markers",
            "source": points.source or "",
            "frame_mirrored": int(closed_form.mirrored),
            "sampler": _describe(self.sampler, density.ndim),
        }
        tree = posterior.posterior_tree(out, units=units, attrs=attrs, observed=observed, dims=dims, coords=coords)
        mean = draws.reshape(-1, draws.shape[-1]).mean(axis=0)
        residuals = density.residuals_by_marker(mean)
        summary_mean = {name: float(np.mean(out[name])) for name in ("L", "a_x", "a_y", "phi")}
        geometry = CompensatorGeometry(
            summary_mean["L"] * MM, summary_mean["a_x"] * MM, summary_mean["a_y"] * MM, summary_mean["phi"] * DEG
        )
        diagnostics = posterior.diagnostics(tree)
        posterior.warn_if_unconverged(diagnostics, what="the geometry posterior")
        return GeometryPosterior(
            tree=tree,
            closed_form=closed_form,
            geometry=geometry,
            residuals=residuals,
            residuals_rms={name: _rms(r) for name, r in residuals.items()},
            convergence=diagnostics,
            cylinder_model=self.cylinder_model,
        )


def _rms(residuals: np.ndarray) -> float:
    """Root mean square of residual vectors' lengths (or of scalar residuals)."""
    return float(np.sqrt(np.mean(np.sum(residuals.reshape(residuals.shape[0], -1) ** 2, axis=1))))


def _describe(sampler: Sampler, ndim: int) -> str:
    describe = getattr(sampler, "describe", None)
    return describe(ndim) if describe is not None else type(sampler).__name__


class _Density:
    """Log-posterior of the geometry with the noise σ's integrated out (SI).

    The sampled vector holds the locations only: ``p2, L, phi, p0`` and the
    cylinder offsets (radii, and angles for the rigid model).  Given them,
    each marker group's likelihood is ``σ^-n exp(-S/2σ²)`` times factors free
    of σ (``S`` the group's residual sum of squares, ``n`` its number of
    informative coordinates), so the log-uniform prior integrates it to
    ``Γ(n/2) (S/2)^(-n/2) [P(n/2, S/2σ_min²) - P(n/2, S/2σ_max²)] / 2`` with
    ``P`` the regularized incomplete gamma function, and σ is drawn afterwards
    from its exact conditional.  For concentric markers this uses the
    large-argument form ``I0e(x) = (2π x)^(-1/2) (1 + 1/(8x) + …)`` without
    the ``1/(8x)`` term: ``x = dR/σ²`` exceeds 10⁵ for any σ below 0.5 mm at
    radii near 190 mm, so the neglected density factor is below 10⁻⁵.

    Every method takes one parameter vector ``(ndim,)`` or a batch
    ``(..., ndim)`` (``vectorized``: samplers may evaluate whole batches in
    one call).
    """

    vectorized = True

    def __init__(self, points: MarkerPoints, closed_form: GeometryFit, model: CylinderModel, priors: GeometryPriors) -> None:
        self.model = model
        self.priors = priors
        self.closed_form = closed_form
        self.sense = closed_form.lever.sense
        self.q1, self.p1 = points.of(LEVER_MARKER)
        self.cylinder_names = points.cylinder_markers
        mask = points.marker != LEVER_MARKER
        self.cq = points.q2[mask]
        self.cp = points.xyz[mask]
        self.cindex = np.array([self.cylinder_names.index(m) for m in points.marker[mask]])
        k = len(self.cylinder_names)
        self.k = k
        self.n_offset = 2 * k if model == "rigid" else k
        self.ndim = 6 + self.n_offset
        self.phi_centre = closed_form.lever.phi
        self.delta_centre = self._delta_start() if model == "rigid" else np.zeros(k)
        per_point = 2 if model == "rigid" else 1
        # Informative coordinates of each noise group: the lever marker, the cylinder markers.
        self.counts = np.array([2.0 * self.q1.size, per_point * self.cq.size])
        self._a = 0.5 * self.counts
        self._negligible = np.array([_inner_range(a, _NEGLIGIBLE_MASS) for a in self._a]).T

    def unpack(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Named parameters; ``theta`` has the parameters along its last axis."""
        k = self.k
        out = {
            "p2": theta[..., 0:2],
            "L": theta[..., 2],
            "phi": theta[..., 3],
            "p0": theta[..., 4:6],
            "radius": theta[..., 6 : 6 + k],
        }
        if self.model == "rigid":
            out["delta"] = theta[..., 6 + k : 6 + 2 * k]
        return out

    def _lever_at(self, p: dict[str, np.ndarray], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """x and y of P1 at the angles ``q`` (n,), each ``(..., n)``."""
        angle = lever_angle(p["phi"][..., None], self.sense, q)
        return lever_points(p["p2"][..., 0:1], p["p2"][..., 1:2], p["L"][..., None], angle)

    def _cylinder_direction(self, p: dict[str, np.ndarray], q: np.ndarray) -> np.ndarray:
        x, y = self._lever_at(p, q)
        return cylinder_direction(x, y, p["p0"][..., 0:1], p["p0"][..., 1:2])

    def _parts(self, p: dict[str, np.ndarray]) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...], np.ndarray | None]:
        """Residual components of P1 ``(dx, dy)`` and of the cylinder points (``(radial,)`` or ``(dx, dy)``),
        each ``(..., n)``, and the cylinder points' distances from p0 (concentric model)."""
        x, y = self._lever_at(p, self.q1)
        lever = (self.p1[:, 0] - x, self.p1[:, 1] - y)
        dx = self.cp[:, 0] - p["p0"][..., 0:1]
        dy = self.cp[:, 1] - p["p0"][..., 1:2]
        radius = p["radius"][..., self.cindex]
        if self.model == "concentric":
            distance = np.sqrt(dx * dx + dy * dy)
            return lever, (distance - radius,), distance
        angle = self._cylinder_direction(p, self.cq) + p["delta"][..., self.cindex]
        return lever, (dx - radius * np.cos(angle), dy - radius * np.sin(angle)), None

    def residuals(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residuals of P1 (``(..., n1, 2)``) and of the cylinder points (radial ``(..., m)`` or ``(..., m, 2)``)."""
        lever, cylinder, _ = self._parts(self.unpack(np.asarray(theta, dtype=float)))
        return np.stack(lever, axis=-1), cylinder[0] if len(cylinder) == 1 else np.stack(cylinder, axis=-1)

    @staticmethod
    def _sums(lever: tuple[np.ndarray, ...], cylinder: tuple[np.ndarray, ...]) -> np.ndarray:
        out = np.empty((*lever[0].shape[:-1], 2))
        out[..., 0] = sum((c * c).sum(axis=-1) for c in lever)
        out[..., 1] = sum((c * c).sum(axis=-1) for c in cylinder)
        return out

    def sums_of_squares(self, theta: np.ndarray) -> np.ndarray:
        """Residual sum of squares of each noise group (lever marker, cylinder markers): ``(..., 2)``."""
        lever, cylinder, _ = self._parts(self.unpack(np.asarray(theta, dtype=float)))
        return self._sums(lever, cylinder)

    def _gamma_bounds(self, sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        half = 0.5 * sums
        return half / self.priors.sigma_max**2, half / self.priors.sigma_min**2

    def __call__(self, theta: np.ndarray) -> float | np.ndarray:
        """Log-density (up to a constant) of one vector ``(ndim,)`` (a float) or of a batch ``(..., ndim)``."""
        theta = np.asarray(theta, dtype=float)
        p = self.unpack(theta)
        radius = p["radius"]
        inside = (
            (p["L"] > 0)
            & (p["L"] < self.priors.length_max)
            & (np.abs(p["phi"] - self.phi_centre) <= math.pi)
            & np.all((radius > 0) & (radius < self.priors.length_max), axis=-1)
        )
        if self.model == "rigid":
            inside &= np.all(np.abs(p["delta"] - self.delta_centre) <= math.pi, axis=-1)
        if theta.ndim == 1 and not inside:
            return -math.inf
        log_prior = -0.5 * ((p["p2"] ** 2).sum(axis=-1) + (p["p0"] ** 2).sum(axis=-1)) / self.priors.position_sd**2
        lever, cylinder, distance = self._parts(p)
        sums = self._sums(lever, cylinder)
        inside &= np.all(sums > 0, axis=-1)
        # Outside the support (a zero sum of squares, a negative radius) the logs below are not finite;
        # such values are replaced by -inf.
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            log_lik = (self._log_noise_mass(sums) - self._a * np.log(0.5 * sums)).sum(axis=-1)
            if distance is not None:
                log_lik -= 0.5 * np.log(distance * radius[..., self.cindex]).sum(axis=-1)
        value = np.where(inside & np.isfinite(log_lik), log_prior + log_lik, -math.inf)
        return float(value) if theta.ndim == 1 else value

    def _log_noise_mass(self, sums: np.ndarray) -> np.ndarray:
        """``log[P(a, S/2σ_min²) - P(a, S/2σ_max²)]``, the noise prior's share of each group's σ integral ``(..., 2)``.

        Zero (to rounding) where the share outside the prior is below ``_NEGLIGIBLE_MASS`` (see
        :func:`_inner_range`), as it is for residual scales well inside the prior; computed elsewhere.
        """
        lo, hi = self._gamma_bounds(sums)
        a = self._a
        out = np.zeros(sums.shape)
        needed = (lo > self._negligible[0]) | (hi < self._negligible[1])
        if needed.any():
            for group in range(a.size):
                rows = needed[..., group]
                out[..., group][rows] = _log_gamma_mass(a[group], lo[..., group][rows], hi[..., group][rows])
        return out

    def draw_sigma(self, draws: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Draw each group's σ from its conditional given each location draw.

        ``draws`` has shape ``(..., ndim)``; the result ``(..., 2)`` (lever, cylinder).
        """
        sums = self.sums_of_squares(draws)
        lo, hi = self._gamma_bounds(sums)
        # sigma² = S / (2u) with u ~ Gamma(n/2) truncated to the prior's bounds.
        u = _truncated_gamma(0.5 * self.counts, lo, hi, rng)
        return np.sqrt(0.5 * sums / u)

    def residuals_by_marker(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        lever, cylinder = self.residuals(theta)
        return {LEVER_MARKER: lever} | {name: cylinder[self.cindex == j] for j, name in enumerate(self.cylinder_names)}

    def _delta_start(self) -> np.ndarray:
        cf = self.closed_form
        p = {"p2": cf.lever.centre, "L": np.asarray(cf.lever.radius), "phi": np.asarray(cf.lever.phi), "p0": cf.cylinder.centre}
        theta = self._cylinder_direction(p, self.cq)
        d = self.cp - cf.cylinder.centre
        offset = np.arctan2(d[:, 1], d[:, 0]) - theta
        return np.array([np.angle(np.mean(np.exp(1j * offset[self.cindex == j]))) for j in range(self.k)])

    def start(self) -> np.ndarray:
        """The closed-form estimate."""
        cf = self.closed_form
        radii = np.array([cf.cylinder.radii[name] for name in self.cylinder_names])
        offsets = np.r_[radii, self.delta_centre] if self.model == "rigid" else radii
        return np.r_[cf.lever.centre, cf.lever.radius, cf.lever.phi, cf.cylinder.centre, offsets]

    def scale(self, theta: np.ndarray) -> np.ndarray:
        """Approximate posterior sd at ``theta`` (Gauss-Newton), the size of the sampler's initial ball."""
        sigma = np.sqrt(self.sums_of_squares(theta) / self.counts)
        steps = 1e-7 * np.maximum(np.abs(theta), 1e-3)
        shifted = theta + np.vstack([np.zeros(theta.size), np.diag(steps)])
        lever, cylinder = self.residuals(shifted)
        whitened = np.concatenate([lever.reshape(len(shifted), -1) / sigma[0], cylinder.reshape(len(shifted), -1) / sigma[1]], axis=1)
        jac = ((whitened[1:] - whitened[0]) / steps[:, None]).T
        return np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac)))


_NEGLIGIBLE_MASS = 1e-17
"""Bound on a σ integral's share outside the noise prior below which its log, ``log(1 - share)``,
is taken as 0: the error is then below the rounding of any log-density (dimensionless)."""

_REJECTION_LIMIT = 0.5
"""Largest bound on the truncated share of a σ conditional drawn by rejection (each try is
then accepted with probability at least 1/2); beyond it σ is drawn by inverting its CDF."""


def _log_gamma_mass(a: float, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``log[P(a, hi) - P(a, lo)]`` for ``0 <= lo <= hi`` and ``a`` a positive multiple of 1/2.

    ``P`` (and ``Q = 1 - P``) are the regularized incomplete gamma functions.
    Each is taken from the form that is accurate on its side of ``x = a`` (see
    :func:`_regularized_gamma`), and the difference is formed from the small
    ones, so that no digits cancel: the exact value, to rounding, at every
    residual scale, with NumPy and the standard library only (``scipy.special``
    would add a quarter of a second to the command line's start).
    """
    p_lo, q_lo = _regularized_gamma(a, lo)
    p_hi, q_hi = _regularized_gamma(a, hi)
    mass = np.where(hi < a, p_hi - p_lo, np.where(lo >= a, q_lo - q_hi, 1.0 - p_lo - q_hi))
    with np.errstate(divide="ignore"):
        return np.log(mass)


def _regularized_gamma(a: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``P(a, x)`` and ``Q(a, x)`` for ``a`` a positive multiple of 1/2 and ``x >= 0``.

    Below ``x = a``, ``P`` from its power series
    ``x^a e^-x / Γ(a+1) · Σ_k x^k / ((a+1)…(a+k))`` (terms shrink at least as
    fast as ``x / (a+1)`` after the first); from ``x = a`` on, ``Q`` from its
    closed form, ``e^-x Σ_{k<a} x^k / k!`` for whole ``a`` and
    ``erfc(√x) + e^-x Σ_{k<a-1/2} x^(k+1/2) / Γ(k+3/2)`` for half-whole ``a``.
    The other is one minus it.
    """
    shape = np.shape(x)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    p = np.zeros(x.shape)
    low = x < a
    if low.any():
        xl = x[low]
        term = np.ones(xl.shape)
        total = np.ones(xl.shape)
        k = 0
        while np.any(term > np.finfo(float).eps * total):
            k += 1
            term = term * xl / (a + k)
            total += term
        with np.errstate(divide="ignore"):
            p[low] = np.exp(a * np.log(xl) - xl - math.lgamma(a + 1.0)) * total
    q = 1.0 - p
    high = ~low
    if high.any():
        xh = x[high]
        whole = float(a).is_integer()
        powers = np.arange(a) if whole else np.arange(a - 0.5) + 0.5
        log_terms = powers * np.log(xh)[:, None] - xh[:, None] - np.array([math.lgamma(k + 1.0) for k in powers])
        tail = np.sum(np.exp(log_terms), axis=1)
        if not whole:
            tail += np.array([math.erfc(math.sqrt(v)) for v in xh])
        q[high] = tail
        p[high] = 1.0 - tail
    return p.reshape(shape), q.reshape(shape)


def _inner_range(a: float, share: float) -> tuple[float, float]:
    """``(lo_max, hi_min)`` such that Gamma(a) puts less than ``share`` outside ``[lo, hi]``
    whenever ``lo <= lo_max`` and ``hi >= hi_min``.

    From the bounds ``P(a, x) <= x^a / Γ(a+1)`` (as ``e^-t <= 1``) and, for
    ``x > c = max(a - 1, 0)``, ``Q(a, x) <= x^(a-1) e^-x / (Γ(a) (1 - c/x))``
    (as ``(1 + u/x)^c <= e^(cu/x)``), each held to ``share / 2``; the second,
    decreasing in ``x`` from ``x = a`` on, is solved by bisection.
    """
    target = math.log(share / 2)
    lo_max = math.exp((target + math.lgamma(a + 1.0)) / a)
    c = max(a - 1.0, 0.0)

    def excess(x: float) -> float:
        return (a - 1.0) * math.log(x) - x - math.lgamma(a) - math.log1p(-c / x) - target

    left, right = a + 1.0, 2.0 * (a + 1.0)
    while excess(right) > 0:
        left, right = right, 2.0 * right
    for _ in range(60):
        middle = 0.5 * (left + right)
        left, right = (middle, right) if excess(middle) > 0 else (left, middle)
    return lo_max, right


def _truncated_gamma(a: np.ndarray, lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draws of Gamma(a, 1) truncated to ``[lo, hi]``; ``a`` is ``(groups,)``, ``lo`` and ``hi`` ``(..., groups)``."""
    lo_max, hi_min = np.array([_inner_range(value, _REJECTION_LIMIT) for value in a]).T
    easy = ((lo <= lo_max) & (hi >= hi_min)).ravel()
    shape = lo.shape
    a, lo, hi = (np.broadcast_to(x, shape).ravel() for x in (a, lo, hi))
    out = np.empty(lo.size)
    pending = np.flatnonzero(easy)
    while pending.size:
        draw = rng.gamma(a[pending])
        kept = (lo[pending] <= draw) & (draw <= hi[pending])
        out[pending[kept]] = draw[kept]
        pending = pending[~kept]
    hard = ~easy
    if hard.any():
        from scipy.special import gammainc, gammaincinv

        p_lo, p_hi = gammainc(a[hard], lo[hard]), gammainc(a[hard], hi[hard])
        out[hard] = gammaincinv(a[hard], p_lo + rng.uniform(size=p_lo.size) * (p_hi - p_lo))
    return out.reshape(shape)
