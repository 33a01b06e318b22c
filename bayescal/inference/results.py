"""What an elastostatic identification found: draws, the posterior DataTree and the results object."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from bayescal.inference.closedform import ClosedForm
from bayescal.inference.equations import DeflectionEquations
from bayescal.inference.identifiability import Identifiability
from bayescal.inference.parameters import (
    ANGLE_DECIMALS,
    ANGLE_FORMAT,
    COMPLIANCE_UNIT,
    GEOMETRY_PARAMETERS,
    ParameterRegistry,
    is_per_angle_variable,
    label_angle,
)
from bayescal.inference.lack_of_fit import LackOfFit
from bayescal.inference.priors import GeometryPrior
from bayescal.jsonsafe import json_safe
from bayescal.cell.config import DEFAULT_COMPENSATED_JOINT
from bayescal.robot.compensator import Compensator, law_on
from bayescal.robot.laws import CompensatorLaw, LawParameter
from bayescal.sampling.gibbs import ConditionallyLinear
from bayescal.sampling.summary import converged, diagnostics
from bayescal.units import DEG, MM, URAD_PER_NM

__all__ = ["ElastostaticResults", "ElastostaticDraws", "edge_point", "linearisation_attrs", "stored_point"]

def linearisation_attrs(law: tuple[LawParameter, ...]) -> tuple[str, ...]:
    """The posterior tree's attributes of the law's values and link-mass scale the exact model's correction was
    linearised about, when not the config's and the URDF's masses (``linearised_K_c_N_per_mm``, ``linearised_s0_mm``,
    ``linearised_mass_scale`` for the spring)."""
    return (*(f"linearised_{p.key}" for p in law), "linearised_mass_scale")


def edge_point(point: tuple[float, ...], law: tuple[LawParameter, ...]) -> tuple[float, ...]:
    """``(*law values, mass scale)`` from SI to the law's edge units (N/mm, mm for the spring) and 1."""
    return (*(v / p.si_factor for v, p in zip(point[:-1], law)), point[-1])


def stored_point(tree, law: tuple[LawParameter, ...]) -> tuple[float, ...] | None:
    """The linearisation point (SI) a saved posterior records; None when it was the config's."""
    names = linearisation_attrs(law)
    if not all(name in tree.attrs for name in names):
        return None
    *values, masses = (float(tree.attrs[name]) for name in names)
    return (*(v * p.si_factor for v, p in zip(values, law)), masses)


@dataclass(frozen=True)
class ElastostaticDraws:
    """Posterior draws in SI, each of shape ``(chain, draw[, ...])``.

    Attributes
    ----------
    compliances : dict
        ``{"k1": ..., "k2": ..., ...}`` joint compliances (rad/(N·m)) of the sampled joints;
        ``k2`` is ``1/K_theta2^0`` (joint 2 without its compensator) in the compensated model.
    spring : numpy.ndarray or None
        ``(chain, draw, 1 + p)``: ``K_theta2^0`` (N·m/rad) and the law's values in SI (``K_c`` N/m, ``s0`` m for the
        spring); None in the per-angle model.
    k2 : numpy.ndarray
        ``(chain, draw, m)`` equivalent joint-2 compliance (rad/(N·m)) at each campaign angle.
    sigma : numpy.ndarray
        ``(chain, draw, groups)`` noise sd per group (m).
    geometry : numpy.ndarray or None
        ``(chain, draw, 4)``: ``L, a_x, a_y`` (m), ``phi`` (rad) when the geometry was sampled.
    gravity : numpy.ndarray or None
        ``(chain, draw)`` scale of the link masses, when the exact model sampled it.
    """

    compliances: dict[str, np.ndarray]
    spring: np.ndarray | None
    k2: np.ndarray
    sigma: np.ndarray
    geometry: np.ndarray | None
    gravity: np.ndarray | None = None

    @classmethod
    def compensated(cls, posterior: ConditionallyLinear, joints: tuple[int, ...], raw: np.ndarray, joint: int) -> ElastostaticDraws:
        """From draws ``(chain, draw, ndim)`` of :func:`~bayescal.inference.likelihood.compensated_posterior`; ``joint`` is the compensated one (0-based)."""
        p, block = len(joints), posterior.block
        z = raw[..., p : p + block.ndim]
        k2 = block.evaluate(z.reshape(-1, block.ndim))[0].reshape(*raw.shape[:2], -1)
        compliances = {f"k{j + 1}": raw[..., i] for i, j in enumerate(joints)}
        spring = block.spring(z.reshape(-1, block.ndim)).reshape(*raw.shape[:2], -1)
        compliances[f"k{joint + 1}"] = 1.0 / spring[..., 0]
        gravity = block.gravity_scale(z.reshape(-1, block.ndim))
        a = block.n_adapted
        return cls(
            compliances=compliances,
            spring=spring,
            k2=k2,
            sigma=np.exp(raw[..., p + block.ndim :]),
            geometry=z[..., a : a + 4] if block.ndim > a else None,
            gravity=None if gravity is None else gravity.reshape(raw.shape[:2]),
        )

    @classmethod
    def per_angle(cls, equations: DeflectionEquations, free: np.ndarray, raw: np.ndarray) -> ElastostaticDraws:
        """From draws ``(chain, draw, ndim)`` of :func:`~bayescal.inference.likelihood.per_angle_posterior`."""
        columns = [c for c, keep in zip(equations.per_angle_columns(), free) if keep]
        compliances: dict[str, np.ndarray] = {}
        k2 = np.full((*raw.shape[:2], equations.compensated_angles.size), np.nan)
        for i, (joint, angle) in enumerate(columns):
            if angle is None:
                compliances[f"k{joint + 1}"] = raw[..., i]
            else:
                k2[..., angle] = raw[..., i]
        return cls(compliances=compliances, spring=None, k2=k2, sigma=np.exp(raw[..., len(columns) :]), geometry=None)

    @classmethod
    def from_tree(cls, tree, equations: DeflectionEquations) -> ElastostaticDraws:
        """The draws a saved posterior holds: the inverse of :meth:`tree` for the campaign of ``equations``.

        Raises
        ------
        ValueError
            When the tree's per-angle angles (``k2_q2`` on ``q2_deg`` for the KR-270) or noise groups are not
            those of ``equations`` (the posterior was computed from another campaign, noise model or cell).
        """
        posterior = tree["posterior"]
        registry = equations.registry
        variable, dimension = registry.per_angle_variable, registry.angle_dimension

        def values(name: str) -> np.ndarray:
            return np.asarray(posterior[name].values, dtype=float)

        if "sigma" not in posterior or not any(name in posterior for name in registry.names):
            raise ValueError("the posterior has no joint compliance or no 'sigma' variable: it is not an elastostatic posterior")
        if variable is not None and variable not in posterior:
            raise ValueError(f"it lacks the per-angle compliances '{variable}' of the cell's compensated joint")
        if variable is None and any(is_per_angle_variable(str(name)) for name in posterior.data_vars):
            raise ValueError("it has per-angle compliances, and the cell has no compensator")
        angles = [ANGLE_FORMAT.format(v) for v in equations.compensated_angles / DEG]
        saved = [str(v) for v in posterior[dimension].values] if variable is not None else []
        if not set(saved) <= set(angles):
            raise ValueError(f"its q2 angles ({', '.join(saved)} deg) are not the campaign's ({', '.join(angles)} deg)")
        groups = tuple(str(v) for v in posterior["noise_group"].values)
        if groups != equations.group_names:
            raise ValueError(f"its noise groups ({', '.join(groups)}) are not the campaign's ({', '.join(equations.group_names)})")
        chains_draws = values("sigma").shape[:2]
        k2 = np.full((*chains_draws, equations.compensated_angles.size), np.nan)
        if saved:
            k2[..., [angles.index(a) for a in saved]] = values(variable) * URAD_PER_NM
        joints = [p for p in registry.parameters if p.name.startswith("k")]
        compliances = {p.name: p.to_si(values(p.name)) for p in joints if p.name in posterior}
        spring = None
        law = registry.law_names
        if law and law[0] in posterior:
            own = 1.0 / compliances[f"k{equations.joint + 1}"]
            spring = np.stack([own, *(registry[name].to_si(values(name)) for name in law)], axis=-1)
        geometry = None
        if "L" in posterior:
            geometry = np.stack([p.to_si(values(p.name)) for p in GEOMETRY_PARAMETERS], axis=-1)
        gravity = values("gravity_scale") if "gravity_scale" in posterior else None
        return cls(compliances=compliances, spring=spring, k2=k2, sigma=values("sigma") * MM, geometry=geometry, gravity=gravity)

    def tree(self, equations: DeflectionEquations):
        """The draws as a posterior DataTree in the registry's edge units (:class:`~bayescal.inference.parameters.ParameterRegistry`),
        the per-angle compliances (``k2_q2`` for the KR-270) on the compensated joint's angle in degrees."""
        from bayescal.sampling.summary import posterior_tree

        registry = equations.registry
        values: dict[str, np.ndarray] = {name: registry[name].to_edge(value) for name, value in sorted(self.compliances.items())}
        units = {name: registry[name].unit for name in values}
        dims: dict[str, list[str]] = {"sigma": ["noise_group"]}
        coords: dict[str, list[str]] = {"noise_group": list(equations.group_names)}
        if self.spring is not None:
            for i, name in enumerate(registry.law_names, start=1):
                values[name] = registry[name].to_edge(self.spring[..., i])
                units[name] = registry[name].unit
        variable = registry.per_angle_variable
        if variable is not None:
            keep = ~np.all(np.isnan(self.k2), axis=(0, 1))
            values[variable] = self.k2[..., keep] / URAD_PER_NM
            units[variable] = COMPLIANCE_UNIT
            dims[variable] = [registry.angle_dimension]
            coords[registry.angle_dimension] = [ANGLE_FORMAT.format(v) for v in equations.compensated_angles[keep] / DEG]
        values["sigma"] = self.sigma / MM
        units["sigma"] = "mm"
        if self.gravity is not None:
            values["gravity_scale"] = self.gravity
            units["gravity_scale"] = "1"
        if self.geometry is not None:
            for i, parameter in enumerate(GEOMETRY_PARAMETERS):
                values[parameter.name] = parameter.to_edge(self.geometry[..., i])
                units[parameter.name] = parameter.unit
        return posterior_tree(values, units=units, dims=dims, coords=coords)


@dataclass
class ElastostaticResults:
    """What :meth:`ElastostaticModel.fit` found.

    Attributes
    ----------
    tree : xarray.DataTree
        The posterior (edge units, see :attr:`registry`; ``k2_q2`` (``k<j>_q<j>``) the
        equivalent compliance of the compensated joint at each campaign angle, ``sigma`` the noise
        per group in mm, and the geometry when it was sampled).
    identifiability : Identifiability
        Structural reasons, and the practical ones found after sampling.
    closed_form : ClosedForm
        Estimates of eqs 33-34 (after the exact model's correction when used).
    model : str
        ``"exact"`` or ``"linear"``.
    compensated_angles : numpy.ndarray
        The campaign's distinct angles (rad) of the compensated joint (``q2`` on the KR-270); empty without a compensator.
    n_equations, n_rows : int
        Scalar equations (3 per campaign row) and campaign rows.
    residual_rms : float
        RMS residual (m) of the model at the posterior mean of its parameters.
    chi2_per_dof : float | None
        Chi-square per degree of freedom of those residuals against the nominal tracker noise.
    nonlinearity : float
        Largest difference between the exact and the linear model's prediction (m).
    iterations : int
        Relinearisations of the exact model.
    residuals : numpy.ndarray
        ``(N, 3)`` residual of each campaign row's deflection after the closed-form fit
        (eqs 33-34, with the exact model's correction when used), base axes, m.
    linear_closed_form : ClosedForm | None
        Estimates of eqs 33-34 without the exact model's correction.
    summary_table : pandas.DataFrame | None
        :meth:`summary`, once computed.
    lack_of_fit : LackOfFit | None
        The lack-of-fit test against the repeats' pure error (None without repeats).
    joint : int or None
        Index (0-based) of the compensated joint, whose compliance is per angle; None without a compensator.
    prismatic : tuple of bool
        Which joints are prismatic (compliance in μm/N at the edges); empty: all revolute.
    law : CompensatorLaw or None
        The compensator's law at the geometry prior's mean; None: the spring of eqs 4-9.
    """

    tree: object
    identifiability: Identifiability
    closed_form: ClosedForm
    model: str
    compensated_angles: np.ndarray
    draws: ElastostaticDraws = field(repr=False)
    geometry: GeometryPrior = field(repr=False)
    n_equations: int = 0
    n_rows: int = 0
    residual_rms: float = math.nan
    chi2_per_dof: float | None = None
    nonlinearity: float = 0.0
    iterations: int = 0
    residuals: np.ndarray = field(default_factory=lambda: np.empty((0, 3)), repr=False)
    linear_closed_form: ClosedForm | None = None
    summary_table: pd.DataFrame | None = field(default=None, repr=False)
    joint: int | None = DEFAULT_COMPENSATED_JOINT
    prismatic: tuple[bool, ...] = ()
    sampler_name: str = "gibbs"
    lack_of_fit: LackOfFit | None = None
    law: CompensatorLaw | None = None

    @property
    def registry(self) -> ParameterRegistry:
        """The identified parameters of this robot: names, units, SI factors (no published values: the cell has them)."""
        return ParameterRegistry(self.closed_form.compliances.size, self.prismatic, self.joint, law=(self.law or Compensator).PARAMETERS)

    @property
    def parameter_units(self) -> dict[str, str]:
        """The reported parameters and their units at the edges (:attr:`registry`)."""
        return self.registry.units

    def save(self, path) -> None:
        """Write the posterior DataTree to NetCDF at ``path``."""
        from bayescal.sampling.summary import save

        save(self.tree, path)

    def document(self, test_pose, source: str, seed: int, reference_file=None):
        """The calibration with its test pose as one document (:mod:`bayescal.summary`): the text ``bayescal calibrate``
        prints, and its Markdown, HTML and JSON (:func:`~bayescal.inference.document.calibration_document`)."""
        from bayescal.inference.document import calibration_document

        return calibration_document(self, test_pose, source, seed, reference_file)

    def summary(self) -> pd.DataFrame:
        """Mean, sd, ±3σ and central 99.73 % intervals, R-hat, ESS and unit of every posterior variable."""
        if self.summary_table is None:
            # A fit and a restore give their summary (R-hat and ESS of every variable take a good
            # part of a second); results built otherwise compute it on each call.
            from bayescal.sampling.summary import summarize

            return summarize(self.tree)
        return self.summary_table.copy()

    def parameters(self) -> dict[str, dict]:
        """The CLI's ``parameters`` block: k1..k<n>, K_c, s0, each an estimate or ``{"identifiable": false, "reason"}``.

        A parameter is given as an estimate (mean, sd, ``lo3``/``hi3`` = mean ∓ 3 sd,
        ``q_lo3``/``q_hi3`` the central 99.73 % interval, unit) only when it is
        identifiable both structurally and from these data
        (:attr:`Identifiability.not_identifiable`); a flagged parameter that was
        sampled carries its posterior summary under ``"posterior"``, for
        inspection, not as an estimate.
        """
        from bayescal.sampling.summary import parameters_json

        summary = self.summary()
        reasons = self.identifiability.not_identifiable
        units = self.parameter_units
        known = parameters_json(summary.loc[[name for name in units if name in summary.index]])
        out: dict[str, dict] = {}
        for name in units:
            if name in known and name not in reasons:
                out[name] = known[name]
            else:
                out[name] = {"identifiable": False, "reason": reasons.get(name, "not sampled")}
                if name in known:
                    out[name]["posterior"] = known[name]
        return out

    def weakly_determined(self) -> dict[str, dict]:
        """Posterior summary (mean, sd, lo3, hi3, unit) of the sampled parameters that are not identifiable from these data.

        They are kept for inspection, not as estimates: their intervals mostly
        reflect the prior.
        """
        from bayescal.sampling.summary import parameters_json

        summary = self.summary()
        names = [name for name in self.identifiability.practical if name in summary.index]
        return parameters_json(summary.loc[names])

    def diagnostics(self) -> dict:
        """Convergence and fit diagnostics (the CLI's ``diagnostics`` block)."""
        report = diagnostics(self.tree, self.summary())
        report |= {
            "converged": converged(report),
            "model": self.model,
            "sampler": self.sampler_name,
            "n_equations": self.n_equations,
            "residual_rms_mm": self.residual_rms / MM,
            "chi2_per_dof": self.chi2_per_dof,
            "nonlinearity_mm": self.nonlinearity / MM,
            "relinearisations": self.iterations,
            "linearised_at": {name.removeprefix("linearised_"): float(self.tree.attrs[name]) for name in linearisation_attrs(self.registry.law)}
            if all(name in self.tree.attrs for name in linearisation_attrs(self.registry.law))
            else None,
            "lack_of_fit": None if self.lack_of_fit is None else self.lack_of_fit.to_json(),
        }
        return report

    def per_angle(self) -> dict[float, dict]:
        """The compensated joint's equivalent compliance at each campaign angle, keyed by its angle (deg): its posterior
        (``mean``, ``sd``, ``lo3``, ``hi3``, ``unit``) or why it has none (``identifiable``: false, ``reason``);
        empty without a compensator."""
        summary = self.summary()
        reasons = self.identifiability.not_identifiable
        unit = COMPLIANCE_UNIT
        out = {}
        for name in self.identifiability.names:
            angle = label_angle(name)
            if angle is None:
                continue
            if name in reasons or name not in summary.index:
                out[angle] = {"identifiable": False, "reason": reasons[name]}
            else:
                out[angle] = {key: float(summary.loc[name, key]) for key in ("mean", "sd", "lo3", "hi3")} | {"unit": unit}
        return out

    def to_json(self) -> dict:
        """Every result in edge units, as ``bayescal calibrate --json`` prints it (without the test pose):
        ``parameters``, ``weakly_determined``, ``k2_per_angle``, ``diagnostics`` (with the geometry's
        source), ``identifiability`` and, for the exact model, ``linear_vs_exact``.  Non-finite
        numbers are null."""
        out = {
            "parameters": self.parameters(),
            "weakly_determined": self.weakly_determined(),
            "k2_per_angle": {f"{ANGLE_FORMAT.format(angle)} deg": entry for angle, entry in self.per_angle().items()},
            "diagnostics": self.diagnostics() | {"geometry": "none: the cell has no compensator" if self.geometry is None else self.geometry.source},
            "identifiability": self.identifiability.to_json(),
        }
        comparison = self.linear_vs_exact()
        if comparison is not None:
            out["linear_vs_exact"] = {
                str(name): {"shift_in_sd": row["shift_in_sd"], "sd_ratio": row["sd_ratio"]} for name, row in comparison.iterrows()
            }
        return json_safe(out)

    def equivalent_compliance(self, q2: np.ndarray) -> np.ndarray:
        """``(S, n)`` posterior draws of joint 2's equivalent compliance (rad/(N·m)) at angles ``q2`` (rad).

        ``1 / (K_theta2^0 + K_c·a·L·η(q2))`` of eq 8 with every draw of the
        spring and, when it was propagated, of the compensator geometry: the
        paper's Fig. 7 with its uncertainty.  Needs the compensated model (at
        least three q2 angles).
        """
        d = self.draws
        if d.spring is None:
            raise ValueError("the campaign does not identify the compensator model (fewer than three q2 angles)")
        spring = d.spring.reshape(-1, d.spring.shape[-1])
        geometry = d.geometry.reshape(-1, 4) if d.geometry is not None else np.broadcast_to(self.geometry.mean, (spring.shape[0], 4))
        law = law_on(self.law, self.geometry.mean)
        return 1.0 / law.joint_stiffness_of(np.asarray(q2, dtype=float), geometry, spring)

    def linear_vs_exact(self) -> pd.DataFrame | None:
        """How far the linear model of eq 30 would be from the exact one, in posterior sd.

        Both models share the design and differ only by the exact model's
        correction of the deflections, so the linear model's posterior is the
        exact one shifted by the difference of their closed-form estimates
        (eqs 33-34); ``sd_ratio`` is the ratio of their closed-form sds (the
        residual variances differ).  None for the linear model.
        """
        if self.model != "exact":
            return None
        exact, linear = self.closed_form, self.linear_closed_form
        pairs: dict[str, tuple[float, float, float]] = {}
        for index, (joint, angle) in enumerate(exact.columns):
            name = f"k{joint + 1}" if angle is None else self.registry.angle_label(self.compensated_angles[angle])
            ratio = math.sqrt(linear.cov[index, index] / exact.cov[index, index])
            pairs[name] = (exact.per_angle[index] / URAD_PER_NM, linear.per_angle[index] / URAD_PER_NM, ratio)
        if exact.spring is not None and linear.spring is not None:
            pairs[f"k{self.joint + 1}"] = (1.0 / exact.spring[0] / URAD_PER_NM, 1.0 / linear.spring[0] / URAD_PER_NM, math.nan)
            for i, name in enumerate(self.registry.law_names, start=1):
                parameter = self.registry[name]
                pairs[name] = (parameter.to_edge(exact.spring[i]), parameter.to_edge(linear.spring[i]), math.nan)
        summary = self.summary()
        names = [name for name in summary.index if name in pairs]
        shift = np.array([pairs[n][1] - pairs[n][0] for n in names])
        return pd.DataFrame(
            {
                "exact_mean": summary.loc[names, "mean"],
                "linear_mean": summary.loc[names, "mean"] + shift,
                "shift_in_sd": shift / summary.loc[names, "sd"],
                "sd_ratio": [pairs[n][2] for n in names],
                "unit": summary.loc[names, "unit"],
            }
        )

    def compliance_draws(self, q2: float, fill: np.ndarray | None = None) -> np.ndarray | None:
        """``(S, nq)`` posterior draws of the compliances (rad/(N·m)) acting at joint angle ``q2``.

        The compensated joint's entry is its equivalent compliance at ``q2`` (its angle, with
        the compensator); without a compensator ``q2`` is not used.  A joint the campaign cannot identify takes its value from
        ``fill`` (no uncertainty), or makes the result ``None`` without it;
        ``None`` too when the compensator is not identified and ``q2`` is not a
        campaign angle.
        """
        d = self.draws
        n_joints = self.closed_form.compliances.size
        missing = [j for j in range(n_joints) if j != self.joint and f"k{j + 1}" not in d.compliances]
        if missing and fill is None:
            return None
        if self.joint is None:
            columns = [np.full(d.sigma[..., 0].size, fill[j]) if j in missing else d.compliances[f"k{j + 1}"].reshape(-1) for j in range(n_joints)]
            return np.column_stack(columns)
        if d.spring is not None:
            k2 = self.equivalent_compliance(np.array([q2]))[:, 0]
        else:
            match = np.flatnonzero(np.abs(self.compensated_angles - q2) < 0.5 * 10.0**-ANGLE_DECIMALS * DEG)
            if not match.size or np.all(np.isnan(d.k2[..., match[0]])):
                return None
            k2 = d.k2[..., match[0]].reshape(-1)
        columns = [
            k2 if j == self.joint else np.full(k2.size, fill[j]) if j in missing else d.compliances[f"k{j + 1}"].reshape(-1)
            for j in range(n_joints)
        ]
        return np.column_stack(columns)
