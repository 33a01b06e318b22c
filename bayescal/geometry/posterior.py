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

import warnings
from dataclasses import dataclass
from os import PathLike

import numpy as np
import pandas as pd
import xarray as xr

from bayescal.sampling import summary as posterior
from bayescal.robot.compensator import CompensatorGeometry, alpha
from bayescal.errors import InputError
from bayescal.geometry.arcs import CompensatorGeometryModel, GeometryFit, MarkerPoints
from bayescal.jsonsafe import json_safe
from bayescal.geometry.density import CylinderModel, GeometryPriors, _Density
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.sampling.independence import IndependenceSampler
from bayescal.sampling.protocol import Sampler
from bayescal.threads import one_blas_thread
from bayescal.units import DEG, MM

__all__ = ["GeometryPriors", "GeometryPosteriorModel", "GeometryPosterior", "geometry_sampler"]

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

    def document(self, source: str, seed: int, reference: pd.DataFrame | None = None, saved_to: str | None = None):
        """The geometry as one document (:mod:`bayescal.summary`): the text ``bayescal geometry`` prints, and its Markdown,
        HTML and JSON (:func:`~bayescal.geometry.document.geometry_document`, which says what the arguments are)."""
        from bayescal.geometry.document import geometry_document

        return geometry_document(self, source, seed, reference, saved_to)

    def save(self, path: str | PathLike[str]) -> None:
        """Write the posterior DataTree to a NetCDF file."""
        posterior.save(self.tree, path)


def geometry_sampler(name: str = "independence", *, n_chains: int | None = None, n_tune: int | None = None, n_draws: int | None = None) -> Sampler:
    """The sampler of a name, sized for the geometry posterior.

    ``"independence"`` (the default) is independence Metropolis-Hastings with a
    Laplace Student-t proposal.  The geometry posterior (σ integrated out) is a
    product of two nearly Gaussian blocks, each close to a Student t with as many
    degrees of freedom as its group has coordinates beyond its parameters (8 and 8 on
    Table I).  A multivariate t proposal with 4 degrees of freedom has tails
    at least as heavy as that product's in every direction, so the importance
    weights stay bounded; widened 1.4 times over the Laplace sd it accepted
    70 % of proposals on Table I and gave a bulk ESS of 0.41 to 0.50 per
    draw for every parameter (6 seeds, 4 chains of 1500 draws).  Each chain
    starts at a proposal, whose distribution is close to the posterior's, so
    200 discarded steps are ample.

    ``"emcee"`` (the default before the independence sampler) is emcee ensembles with
    differential-evolution and stretch moves.  On Table I the integrated
    autocorrelation time of the geometry posterior is 60-90 steps with emcee's
    stretch move alone and 30-50 with its ``DEMove``, but ``DEMove`` alone steps by
    differences of the other walkers and so returns slowly from the posterior's heavy
    tails (in 1 of 6 seeds a walker strayed 20 posterior sd away for hundreds of
    steps); an 80/20 mixture keeps the speed and lets the scale-free stretch move
    bring strays back.  emcee's ``DESnookerMove`` is not used: on this posterior it
    gave L an sd of 0.020 mm where the exact (Student t) posterior has 0.035 mm.

    Parameters
    ----------
    name
        ``"independence"`` or ``"emcee"``.
    n_chains
        Independent chains (ensembles for emcee); default 4.
    n_tune
        Steps discarded per chain; default 200 (independence) or 1000 (emcee).
    n_draws
        Steps kept per chain (per walker for emcee); default 1000.
    """
    chains = 4 if n_chains is None else int(n_chains)
    draws = 1000 if n_draws is None else int(n_draws)
    if name == "independence":
        tune = 200 if n_tune is None else int(n_tune)
        return IndependenceSampler(n_chains=chains, n_tune=tune, n_draws=draws, dof=4.0, widen=1.4)
    if name == "emcee":
        import emcee

        moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.StretchMove(), 0.2)]
        return EnsembleSampler(n_chains=chains, n_tune=1000 if n_tune is None else int(n_tune), n_draws=draws, moves=moves)
    raise ValueError(f"sampler must be 'independence' or 'emcee', got {name!r}")


class GeometryPosteriorModel:
    """Bayesian model of the compensator geometry (see the module docstring).

    Parameters
    ----------
    cylinder_model
        ``"concentric"`` (the paper's model, default) or ``"rigid"``.
    sampler
        Any :class:`bayescal.sampling.protocol.Sampler`; default :func:`geometry_sampler`
        (``geometry_sampler("emcee")`` gives emcee ensembles).
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
        self.sampler = sampler if sampler is not None else geometry_sampler()
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
        # One BLAS thread, as the command line sets (bayescal/threads.py).
        with one_blas_thread():
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
            "alpha": alpha(phi, a_x, a_y) / DEG,
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
