"""How good a calibration plan is before it is measured: eqs 37-40 on the linearised compensated model.

The identification's parameters are ``θ = [k1..kn, K_c, s0]`` (rad/(N·m), N/m,
m), ``k2`` being joint 2 without its compensator.  Around the cell's nominal
values, a marker's deflection in configuration ``q`` under the wrench ``F`` is
``Δp ≈ A(q, F) k_eff(q2)`` (eq 31) with the equivalent joint-2 compliance
``k_eff2 = 1/(1/k2 + K_c a L η(q2; s0))`` (eq 8); the chain rule through
``k_eff2`` gives the rows of the design ``B`` in ``θ``.  With independent tracker
noise of standard deviation ``σ(p)`` per coordinate (two readings per
deflection), a configuration measured ``r`` times contributes
``r Bᵀ W B`` (``W = 1/(2σ²)``) to the information matrix, and the plan's
covariance is its inverse (eq 37, weighted).  This is the linear-Gaussian
closed form the criteria of eqs 38-39 assume; the Bayesian identification's
posterior agrees with it when the priors are wide and the model nearly linear.

Everything here works in relative parameters ``u = θ/θ_nominal - 1`` so that
the information matrix is well conditioned across rad/(N·m), N/m and m.

Three criteria, all to be minimised:

* ``test-pose``: ``ρ0² = trace(G0 cov G0ᵀ)`` (eqs 38-40), the mean squared
  positioning error left at the cell's test pose ``(q0, F0)`` after compliance
  compensation, with ``G0`` the test pose's eq-31 matrix through the same chain
  rule, so joint 2's compliance at ``q0``'s q2 comes from the compensator model;
* ``compensator``: the sum of the relative variances of ``K_c`` and ``s0``;
* ``d-optimal``: ``-log det`` of the information matrix, as general-purpose
  calibration toolboxes use it.

A joint compliance no configuration of the plan excites (``k1`` under hanging
loads, which exert no torque about the vertical A1 axis) keeps its prior, the
cell's ``[joints] k_log_sd`` log-normal about the cell's value, as it does in
the identification: the compensation applies that value, and the error it
leaves enters ``ρ0`` as it enters every predicted error of the package
(:mod:`bayescal.compensation.budget`).  Such a compliance has no information
from the data, so its share adds to ``ρ0²`` apart: ``|G0_j|² m²``, ``m²`` the
mean square of ``k/k_cell - 1`` under its prior (:func:`prior_mean_square`),
exact for a linear model.  So a hanging plan and a free-direction plan are
scored by one number a user can compare; the data's part alone is
``rho0_identified``.  Its width stays NaN (the eq-37 precision has none), and
``K_c`` and ``s0`` (flat priors) are held at their nominal value when the plan
cannot excite them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from dataclasses import replace

from bayescal.cell.config import Cell
from bayescal.inference.parameters import ParameterRegistry
from bayescal.jsonsafe import json_safe
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.stiffness import ElasticArm, compliance_design
from bayescal.units import MM

__all__ = [
    "CRITERIA",
    "ExactLinearisation",
    "compliance_chain",
    "PlanPrediction",
    "configuration_design",
    "configuration_designs",
    "designs_information",
    "configuration_information",
    "criterion_value",
    "criterion_values",
    "nominal_parameters",
    "parameter_names",
    "predict",
    "prior_mean_square",
    "solve_equilibrium",
    "test_deflection",
    "test_pose_design",
    "with_parameters",
    "wrench_information",
]

CRITERIA = ("test-pose", "compensator", "d-optimal")
"""The criteria a plan can be optimised for."""

UNEXCITED = 1e-18
"""A parameter whose information is below this fraction of the largest is not excited by the plan
(the square of the 1e-9 column-norm ratio of :mod:`bayescal.studies.precision`)."""

SINGULAR = 1e-14
"""Smallest eigenvalue, relative to the largest, of an information matrix that can still be inverted
in double precision: below it the plan cannot separate the parameters (e.g. K_c and s0 from two q2 angles)."""


def parameter_names(cell: Cell) -> list[str]:
    """``k1..k<n>`` and, with a compensator, ``K_c`` and ``s0``: the cell's :class:`~bayescal.inference.parameters.ParameterRegistry`."""
    return ParameterRegistry.of_cell(cell).names


def nominal_parameters(cell: Cell) -> np.ndarray:
    """(p,) the cell's parameter values, SI: rad/(N·m), then N/m and m."""
    values = list(cell.compliances)
    if cell.compensator is not None:
        values += [cell.compensator.K_c, cell.compensator.s0]
    return np.array(values, dtype=float)


def prior_mean_square(log_sd: float) -> float:
    """``E[(k/k_cell - 1)²]`` when ``log(k/k_cell)`` is normal with sd ``log_sd``: the mean-square relative
    error the cell's value (the prior's median, which the correction applies) leaves.  ``0.383`` for 0.5."""
    return math.exp(2.0 * log_sd**2) - 2.0 * math.exp(0.5 * log_sd**2) + 1.0


def _prior_term(cell: Cell, G0: np.ndarray, excited: np.ndarray) -> float:
    """``Σ |G0_j|² m²`` (m²) over the joint compliances not ``excited``: their priors' share of ``ρ0²``."""
    held = ~excited[: cell.robot.nq]
    return float(np.sum(G0[:, : cell.robot.nq][:, held] ** 2)) * prior_mean_square(cell.compliance_log_sd)


def compliance_chain(cell: Cell, q2) -> tuple[np.ndarray, np.ndarray]:
    """Compliances acting at joint angle ``q2`` (joint 2 with its compensator, eq 8) and their (nq, p)
    derivatives in the parameters of :func:`parameter_names` (SI).

    ``q2`` may be an array of shape ``(N,)``: the results are then ``(N, nq)`` and ``(N, nq, p)``.
    """
    q2 = np.asarray(q2, dtype=float)
    k = cell.compliances
    effective = np.array(np.broadcast_to(k, q2.shape + k.shape))
    # The parameters' count, not their registry: building that reads the cell's reference table, once per
    # configuration of a search (half of a 5 × 3 plan's time).
    chain = np.array(np.broadcast_to(np.eye(cell.robot.nq, nominal_parameters(cell).size), q2.shape + (cell.robot.nq, nominal_parameters(cell).size)))
    compensator = cell.compensator
    if compensator is not None:
        j2 = cell.compensated_joint
        effective[..., j2] = 1.0 / (1.0 / k[j2] + compensator.stiffness(q2))
        # K_c·a·L·η = C1·K_c + C2·s0·K_c (eq 35): derivatives C1 + s0·C2 in K_c and K_c·C2 in s0.
        regressor = compensator.regressor(q2)
        c1, c2 = regressor[..., 1], regressor[..., 2]
        chain[..., j2, j2] = effective[..., j2] ** 2 / k[j2] ** 2
        chain[..., j2, -2] = -effective[..., j2] ** 2 * (c1 + compensator.s0 * c2)
        chain[..., j2, -1] = -effective[..., j2] ** 2 * compensator.K_c * c2
    return effective, chain


def configuration_design(cell: Cell, q, wrench) -> tuple[np.ndarray, np.ndarray]:
    """Design rows of one configuration and the noise of each.

    Parameters
    ----------
    cell
        The cell.
    q
        (nq,) joint angles, rad.
    wrench
        (6,) load at the flange origin, base axes, N and N·m.

    Returns
    -------
    design : numpy.ndarray
        (3·markers, p) derivatives of the markers' deflections (m) in the relative parameters,
        rows in the cell's marker order.
    sigma : numpy.ndarray
        (3·markers,) standard deviation of each deflection coordinate (m): ``√2 σ(p)``.
    """
    design, sigma = configuration_designs(cell, np.asarray(q, dtype=float)[np.newaxis], np.asarray(wrench, dtype=float)[np.newaxis])
    return design[0], sigma[0]


def configuration_designs(cell: Cell, q: np.ndarray, wrench: np.ndarray, *, chain: BatchedChain | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`configuration_design` of ``N`` configurations at once, by :class:`~bayescal.robot.batched.BatchedChain`.

    Parameters
    ----------
    q
        ``(N, nq)`` joint angles, rad.
    wrench
        ``(N, 6)`` loads at the flange origin, base axes, N and N·m.
    chain
        The robot's batched chain, when already built.

    Returns
    -------
    design : numpy.ndarray
        ``(N, 3·markers, p)``.
    sigma : numpy.ndarray
        ``(N, 3·markers)``, m.
    """
    q, wrench = np.asarray(q, dtype=float), np.asarray(wrench, dtype=float)
    chain = BatchedChain.of(cell.robot) if chain is None else chain
    _, parameters = compliance_chain(cell, q[:, cell.plan_joint])
    parameters = parameters * nominal_parameters(cell)
    poses = chain.poses(q)
    # eq 31: column j of a marker's A is its Jacobian column j times the torque J_F[:, j] · wrench
    flange_linear, flange_angular = chain.point_jacobian(poses, poses.flange_origin)
    torques = np.einsum("njc,nc->nj", flange_linear, wrench[:, :3]) + np.einsum("njc,nc->nj", flange_angular, wrench[:, 3:])
    points = np.array(list(cell.markers.values()))
    rows = []
    for point in points:
        linear, _ = chain.point_jacobian(poses, poses.points(point))
        rows.append(np.swapaxes(linear * torques[:, :, np.newaxis], 1, 2) @ parameters)
    positions = np.stack([poses.points(point) for point in points], axis=1)
    sigma = math.sqrt(2.0) * cell.tracker.sigma(positions)
    return np.concatenate(rows, axis=1), np.repeat(sigma, 3, axis=-1)


def designs_information(design: np.ndarray, sigma: np.ndarray, repeats: int = 1) -> np.ndarray:
    """``(N, p, p)`` information ``r Bᵀ W B`` of ``N`` configurations' designs ``(N, rows, p)`` with noise ``(N, rows)``, m."""
    weighted = design / sigma[..., np.newaxis]
    return repeats * np.swapaxes(weighted, -1, -2) @ weighted


def configuration_information(cell: Cell, q, mass: float, repeats: int = 1, *, exact: ExactLinearisation | None = None) -> np.ndarray:
    """(p, p) information ``r Bᵀ W B`` of one configuration loaded with ``mass`` kg, relative parameters.

    ``exact``: take ``B`` from the exact model's linearisation instead of eq 31.
    """
    return wrench_information(cell, q, cell.load_wrench(q, mass), repeats, exact=exact)


def wrench_information(cell: Cell, q, wrench, repeats: int = 1, *, exact: ExactLinearisation | None = None) -> np.ndarray:
    """(p, p) information of one configuration under any (6,) ``wrench`` (flange origin, base axes, its force
    through the load point: :meth:`~bayescal.cell.config.Cell.wrench`), relative parameters."""
    if exact is None:
        design, sigma = configuration_design(cell, q, wrench)
    else:
        design, sigma = exact.wrench_design(q, wrench)
    weighted = design / sigma[:, np.newaxis]
    return repeats * weighted.T @ weighted


def test_pose_design(cell: Cell) -> np.ndarray:
    """(3, p) derivative of the test point's deflection (m) under the test wrench in the relative parameters."""
    _, chain = compliance_chain(cell, float(cell.test_q[cell.plan_joint]))
    chain = chain * nominal_parameters(cell)[np.newaxis, :]
    return compliance_design(cell.robot, cell.test_q, cell.test_point, cell.test_wrench) @ chain


test_pose_design.__test__ = False  # a library function, not a pytest test


DIFFERENCE_STEP = 1e-4
"""Relative step of the exact model's central differences: deflections are nearly linear in the
parameters, so the truncation error (order step², relative) stays far below the solves' rounding."""


def with_parameters(cell: Cell, theta: np.ndarray) -> Cell:
    """``cell`` with the parameters ``theta`` = [k1..k<n>, K_c, s0] (SI)."""
    nq = cell.robot.nq
    compensator = cell.compensator
    if compensator is not None:
        compensator = replace(compensator, K_c=float(theta[nq]), s0=float(theta[nq + 1]))
    return replace(cell, compliances=np.array(theta[:nq], dtype=float), compensator=compensator)


def solve_equilibrium(cell: Cell, q, wrench, load_point) -> np.ndarray:
    """(nq,) joint deflections (rad) of ``cell``'s arm at ``q`` under ``wrench``, its force acting at ``load_point``.

    Raises :class:`~bayescal.robot.stiffness.EquilibriumError` when there is none.
    """
    return ElasticArm.linear(cell.robot, cell.compliances, compensator=cell.compensator, load_point=load_point, compensated_joint=cell.compensated_joint).equilibrium(q, wrench)


def test_deflection(cell: Cell) -> np.ndarray:
    """(3,) exact deflection (m) of the test point under the test wrench, its force acting at that point."""
    robot = cell.robot
    states = [solve_equilibrium(cell, cell.test_q, wrench, cell.test_point) for wrench in (np.zeros(6), cell.test_wrench)]
    return robot.point_position(cell.test_q + states[1], cell.test_point) - robot.point_position(cell.test_q + states[0], cell.test_point)


test_deflection.__test__ = False  # a library function, not a pytest test


class ExactLinearisation:
    """The exact model (the twin's loaded equilibrium with the links' weights and the compensator)
    linearised about the cell's values by central differences, in relative parameters.

    The compensator's static torque moves the unloaded and loaded equilibria, so
    ``K_c`` and ``s0`` act on the deflections also through the arm's geometry,
    which eq 31's design leaves out: on Table III the exact model predicts
    K_c and s0 about 2.4 and 1.4 times more precisely than eq 31 (docs/design.md).

    The equilibria of every configuration asked for at once, unloaded and loaded, at the
    cell's values and at each parameter moved up and down, are solved together, in one call
    of :func:`~bayescal.robot.batched.equilibria` whose rows carry their own compliances and spring.
    """

    def __init__(self, cell: Cell) -> None:
        self.cell = cell
        nominal = nominal_parameters(cell)
        self._cells = []
        for i in range(len(nominal)):
            pair = []
            for sign in (1.0, -1.0):
                theta = nominal.copy()
                theta[i] *= 1.0 + sign * DIFFERENCE_STEP
                pair.append(with_parameters(cell, theta))
            self._cells.append(pair)
        self._chain = BatchedChain.of(cell.robot)
        self._points = np.array(list(cell.markers.values()))
        # Variant 0 is the cell itself, then each parameter up and down.
        variants = [cell] + [changed for pair in self._cells for changed in pair]
        self._compliances = np.array([changed.compliances for changed in variants])
        self._springs = None if cell.compensator is None else np.array([[v.compensator.K_c, v.compensator.s0] for v in variants])

    def deflections(self, q, mass: float) -> np.ndarray:
        """(markers, 3) noiseless deflections (m) at the cell's values."""
        return self.wrench_deflections(q, self.cell.load_wrench(q, mass))

    def wrench_deflections(self, q, wrench) -> np.ndarray:
        """(markers, 3) noiseless deflections (m) at the cell's values under any (6,) ``wrench`` (flange origin, base axes)."""
        unloaded, loaded = self._positions(np.asarray(q, dtype=float)[np.newaxis], np.asarray(wrench, dtype=float)[np.newaxis], nominal_only=True)
        return (loaded - unloaded)[0, 0]

    def configuration_design(self, q, mass: float) -> tuple[np.ndarray, np.ndarray]:
        """Like :func:`configuration_design`, from the exact model; the noise is that of the two readings."""
        return self.wrench_design(q, self.cell.load_wrench(q, mass))

    def wrench_design(self, q, wrench) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`configuration_design` under any (6,) ``wrench`` (flange origin, base axes, its force through the load point)."""
        design, sigma = self.wrench_designs(np.asarray(q, dtype=float)[np.newaxis], np.asarray(wrench, dtype=float)[np.newaxis])
        return design[0], sigma[0]

    def wrench_designs(self, q: np.ndarray, wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`wrench_design` of ``N`` configurations at once.

        Parameters
        ----------
        q
            ``(N, nq)`` joint angles, rad.
        wrench
            ``(N, 6)`` loads at the flange origin, base axes, N and N·m, each force through the load point.

        Returns
        -------
        design : numpy.ndarray
            ``(N, 3·markers, p)`` derivatives of the markers' deflections (m) in the relative parameters.
        sigma : numpy.ndarray
            ``(N, 3·markers)`` standard deviation of each deflection coordinate (m), two readings.
        """
        q, wrench = np.asarray(q, dtype=float), np.asarray(wrench, dtype=float)
        unloaded, loaded = self._positions(q, wrench)
        deflection = (loaded - unloaded).reshape(len(self._compliances), len(q), -1)
        design = (deflection[1::2] - deflection[2::2]) / (2.0 * DIFFERENCE_STEP)
        sigma = np.sqrt(self.cell.tracker.deflection_variance(unloaded[0], loaded[0]))
        return np.moveaxis(design, 0, -1), np.repeat(sigma, 3, axis=-1)

    def _positions(self, q: np.ndarray, wrench: np.ndarray, *, nominal_only: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(V, N, markers, 3)`` marker positions (m) unloaded and loaded, for the V variants of the parameters
        (the cell's values alone when ``nominal_only``)."""
        n = len(q)
        cell = self.cell
        variants = 1 if nominal_only else len(self._compliances)
        # rows: variant, then unloaded / loaded, then configuration
        rows_q = np.tile(q, (2 * variants, 1))
        rows_wrench = np.tile(np.concatenate([np.zeros_like(wrench), wrench]), (variants, 1))
        theta = equilibria(
            self._chain, rows_q, rows_wrench, np.repeat(self._compliances[:variants], 2 * n, axis=0),
            compensator=cell.compensator, compensated_joint=cell.compensated_joint, load_point=cell.load_point,
            springs=None if self._springs is None else np.repeat(self._springs[:variants], 2 * n, axis=0),
        )
        poses = self._chain.poses(rows_q + theta)
        positions = np.stack([poses.points(point) for point in self._points], axis=1).reshape(variants, 2, n, len(self._points), 3)
        return positions[:, 0], positions[:, 1]

    def test_design(self) -> np.ndarray:
        """(3, p) derivatives of the test point's exact deflection (m) in the relative parameters."""
        return np.column_stack(
            [(test_deflection(plus) - test_deflection(minus)) / (2.0 * DIFFERENCE_STEP) for plus, minus in self._cells]
        )


@dataclass(frozen=True)
class PlanPrediction:
    """What a plan's information matrix predicts (relative parameters; SI where stated).

    Attributes
    ----------
    names : list of str
    nominal : numpy.ndarray
        (p,) parameter values, SI.
    excited : numpy.ndarray
        (p,) bool, parameters the plan excites; the others are held at their nominal values.
    covariance : numpy.ndarray
        (p, p) covariance of the relative parameters; NaN rows and columns where not
        excited, or everywhere when the plan cannot separate the excited ones.
    rho0 : float
        rms positioning error left at the test pose after compensation (eq 39), m, the priors of the
        compliances the plan does not excite included; inf when the plan cannot predict it.
    rho0_identified : float
        The same with every compliance the plan does not excite held at its applied value: the part
        the plan's data set, m.
    log_det : float
        log det of the excited block of the information matrix (relative parameters); -inf when singular.
    registry : ParameterRegistry
        The cell's parameters: units at the edges, SI factors, and its published results (its
        ``reference_csv``, Table IV for the KR-270) where it names them.
    """

    names: list[str]
    nominal: np.ndarray
    excited: np.ndarray
    covariance: np.ndarray
    rho0: float
    log_det: float
    registry: ParameterRegistry
    rho0_identified: float = math.nan

    @property
    def prior_share(self) -> float:
        """Fraction of ``ρ0²`` from the priors of the compliances the plan does not excite."""
        if not math.isfinite(self.rho0) or self.rho0 == 0:
            return math.nan
        return max(0.0, 1.0 - (self.rho0_identified / self.rho0) ** 2)

    @property
    def relative_sd(self) -> np.ndarray:
        """(p,) standard deviation of each parameter as a fraction of its value (NaN where not excited)."""
        return np.sqrt(np.diag(self.covariance))

    def summary(self) -> pd.DataFrame:
        """Predicted precision per parameter in the paper's units.

        Columns ``value``, ``sd``, ``width_3sd_pct`` (3 sd in % of the value),
        ``table_iv_pct`` (the cell's published widths, Klimchik et al.'s Table IV for the
        KR-270; only when the cell names them) and ``unit``.
        """
        parameters = [self.registry[name] for name in self.names]
        factors = np.array([1.0 / p.si_factor for p in parameters])
        sd = self.relative_sd * np.abs(self.nominal)
        columns = {"value": self.nominal * factors, "sd": sd * factors, "width_3sd_pct": 300.0 * self.relative_sd}
        if self.registry.published is not None:
            columns["table_iv_pct"] = [100.0 * p.published[1] / p.published[0] if p.published else math.nan for p in parameters]
        columns["unit"] = [p.unit for p in parameters]
        return pd.DataFrame(columns, index=pd.Index(self.names, name="parameter"))

    def to_json(self) -> dict:
        """``criterion`` (ρ0 in mm, null when not predictable) and each parameter's ±3σ width."""
        table = self.summary()
        not_excited = [name for name, excited in zip(self.names, self.excited) if not excited and name.startswith("k")]
        return {
            "criterion": json_safe(self.rho0 / MM),
            "criterion_unit": "mm rms at the test pose after compensation",
            "criterion_includes": "the identified parameters' uncertainty and the prior of "
            + (", ".join(not_excited) + ", which the plan does not excite" if not_excited else "no unexcited compliance (every one excited)"),
            "criterion_identified_only": json_safe(self.rho0_identified / MM),
            "criterion_prior_share_of_mean_square": json_safe(self.prior_share),
            "log_det_information": json_safe(self.log_det),
            "parameters": {
                name: {
                    "value": float(row.value),
                    "unit": row.unit,
                    "sd": json_safe(row.sd),
                    "width_3sd": json_safe(3.0 * row.sd),
                    "width_3sd_pct": json_safe(row.width_3sd_pct),
                    "excited": bool(excited),
                }
                for (name, row), excited in zip(table.iterrows(), self.excited)
            },
        }


def predict(cell: Cell, information: np.ndarray, *, test_design: np.ndarray | None = None) -> PlanPrediction:
    """The covariance, ``ρ0`` and ``log det`` a plan's information matrix gives.

    Parameters
    ----------
    cell
        The cell (nominal parameters, test pose).
    information
        (p, p) sum of :func:`configuration_information` over the plan.
    test_design
        (3, p) :func:`test_pose_design` of ``cell``, when already computed.
    """
    names = parameter_names(cell)
    p = len(names)
    G0 = test_pose_design(cell) if test_design is None else test_design
    diagonal = np.diag(information)
    excited = diagonal > UNEXCITED * max(diagonal.max(), 1e-300)
    block = information[np.ix_(excited, excited)]
    # Equilibrating the block keeps the eigenvalue test meaningful when one parameter dominates.
    scale = 1.0 / np.sqrt(np.diag(block))
    values, vectors = np.linalg.eigh(block * np.outer(scale, scale))
    covariance = np.full((p, p), np.nan)
    rho0 = rho0_identified = math.inf
    log_det = -math.inf
    if values.size and values[0] > SINGULAR * values[-1]:
        inverse = (vectors / values) @ vectors.T * np.outer(scale, scale)
        covariance[np.ix_(excited, excited)] = inverse
        squared = max(float(np.trace(G0[:, excited] @ inverse @ G0[:, excited].T)), 0.0)
        rho0_identified = math.sqrt(squared)
        rho0 = math.sqrt(squared + _prior_term(cell, G0, excited))
        log_det = float(np.sum(np.log(values)) - 2.0 * np.sum(np.log(scale)))
    return PlanPrediction(
        names=names,
        nominal=nominal_parameters(cell),
        excited=excited,
        covariance=covariance,
        rho0=rho0,
        log_det=log_det,
        registry=ParameterRegistry.of_cell(cell),
        rho0_identified=rho0_identified,
    )


def criterion_value(prediction: PlanPrediction, criterion: str) -> float:
    """The number ``criterion`` minimises (inf for a plan that cannot deliver it).

    ``test-pose``: ``ρ0`` (m); ``compensator``: the sum of the relative variances of
    ``K_c`` and ``s0``; ``d-optimal``: ``-log det`` of the information matrix.
    """
    if criterion == "test-pose":
        return prediction.rho0
    if criterion == "compensator":
        if "K_c" not in prediction.names:
            raise ValueError("the compensator criterion needs a cell with a compensator")
        variance = np.diag(prediction.covariance)[-2:]
        return float(np.sum(variance)) if np.all(np.isfinite(variance)) else math.inf
    if criterion == "d-optimal":
        return -prediction.log_det
    raise ValueError(f"unknown criterion {criterion!r}; expected one of {', '.join(CRITERIA)}")


def criterion_values(
    cell: Cell, information: np.ndarray, criterion: str, *, test_design: np.ndarray | None = None, groups: np.ndarray | None = None
) -> np.ndarray:
    """:func:`criterion_value` of many information matrices at once, as the exchange algorithm needs.

    Parameters
    ----------
    cell
        The cell.
    information
        (n, p, p) information matrices (relative parameters).
    criterion
        One of :data:`CRITERIA`.
    test_design
        (3, p) :func:`test_pose_design` of ``cell``, when already computed.
    groups
        (n,) labels of independent batches scored in one call; None: one batch.

    Returns
    -------
    numpy.ndarray
        (n,) the criterion of each matrix (inf where it cannot be delivered).  The
        parameters held at their nominal value are those no matrix of the batch
        (of the same label) excites; a parameter only some matrices excite makes the others singular.
    """
    if criterion not in CRITERIA:
        raise ValueError(f"unknown criterion {criterion!r}; expected one of {', '.join(CRITERIA)}")
    if criterion == "compensator" and cell.compensator is None:
        raise ValueError("the compensator criterion needs a cell with a compensator")
    n, p = information.shape[0], information.shape[-1]
    if n == 0:
        return np.empty(0)
    labels = np.zeros(n, dtype=int) if groups is None else np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
    diagonal = np.einsum("nii->ni", information)
    peak = np.zeros((labels.max() + 1 if n else 0, p))
    np.maximum.at(peak, labels, diagonal)
    excited = peak > UNEXCITED * np.maximum(peak.max(axis=1, initial=0.0), 1e-300)[:, np.newaxis]
    # Batches that hold the same parameters are scored together: eigh treats every matrix on its own.
    masks, which = np.unique(excited, axis=0, return_inverse=True)
    which = which.ravel()[labels]
    G0 = None if criterion != "test-pose" else test_pose_design(cell) if test_design is None else test_design
    values = np.empty(n)
    for m, mask in enumerate(masks):
        rows = np.flatnonzero(which == m)
        values[rows] = _criterion_values(cell, information[rows], criterion, mask, G0)
    return values


def _criterion_values(cell: Cell, information: np.ndarray, criterion: str, excited: np.ndarray, G0: np.ndarray | None) -> np.ndarray:
    """:func:`criterion_values` of matrices ``(n, p, p)`` that share the ``excited`` parameters ``(p,)``."""
    block = information[:, excited][:, :, excited]
    scale = 1.0 / np.sqrt(np.maximum(np.einsum("nii->ni", block), 1e-300))
    outer = scale[:, :, np.newaxis] * scale[:, np.newaxis, :]
    values, vectors = np.linalg.eigh(block * outer)
    usable = values[:, 0] > SINGULAR * values[:, -1]
    safe = np.where(usable[:, np.newaxis], values, 1.0)
    if criterion == "d-optimal":
        return np.where(usable, -(np.sum(np.log(safe), axis=1) - 2.0 * np.sum(np.log(scale), axis=1)), np.inf)
    inverse = (vectors / safe[:, np.newaxis, :]) @ vectors.transpose(0, 2, 1) * outer
    if criterion == "compensator":
        return np.where(usable, inverse[:, -2, -2] + inverse[:, -1, -1], np.inf)
    squared = np.einsum("ij,njk,ik->n", G0[:, excited], inverse, G0[:, excited])
    return np.where(usable, np.sqrt(np.maximum(squared, 0.0) + _prior_term(cell, G0, excited)), np.inf)
