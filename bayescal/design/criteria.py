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

The covariance and ``ρ0`` of one plan are :func:`bayescal.design.prediction.predict`'s, the exact
model's designs :class:`bayescal.design.linearisation.ExactLinearisation`'s.

Everything here works in relative parameters ``u = θ/θ_nominal - 1`` so that
the information matrix is well conditioned across rad/(N·m), N/m and m.

Three criteria, all to be minimised:

* ``test-pose``: ``ρ0² = trace(G0 cov G0ᵀ)`` (eqs 38-40), the mean squared
  positioning error left at the cell's test pose ``(q0, F0)`` after compliance
  compensation, with ``G0`` the test pose's eq-31 matrix through the same chain
  rule, so joint 2's compliance at ``q0``'s q2 comes from the compensator model;
* ``compensator``: the sum of the relative variances of the compensator law's
  parameters (``K_c`` and ``s0`` for the spring);
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
from typing import Protocol

import numpy as np

from bayescal.cell.config import Cell
from bayescal.inference.parameters import ParameterRegistry
from bayescal.robot.batched import BatchedChain, Poses
from bayescal.robot.stiffness import compliance_design

__all__ = [
    "CRITERIA",
    "compliance_chain",
    "configuration_design",
    "configuration_designs",
    "designs_information",
    "configuration_information",
    "criterion_values",
    "nominal_parameters",
    "parameter_names",
    "prior_mean_square",
    "test_pose_design",
    "wrench_information",
    "WrenchDesigner",
]

CRITERIA = ("test-pose", "compensator", "d-optimal")
"""The criteria a plan can be optimised for."""

UNEXCITED = 1e-18
"""A parameter whose information is below this fraction of the largest is not excited by the plan
(the square of the 1e-9 column-norm ratio of :mod:`bayescal_studies.studies.precision`)."""

SINGULAR = 1e-14
"""Smallest eigenvalue, relative to the largest, of an information matrix that can still be inverted
in double precision: below it the plan cannot separate the parameters (e.g. K_c and s0 from two q2 angles)."""

DECIDED_MARGIN = 100.0
"""How far a Cholesky factor's bound on the smallest eigenvalue must clear :data:`SINGULAR` for the plan to be
scored without its eigenvalues: the bound's own rounding grows with the condition number, and plans within
this factor of the limit are left to ``eigh`` to decide (none of the 126,644 information matrices that
``bayescal plan --config data/kr270.toml --model linear`` scores, nor of the 100,769 of the exact model's search)."""


class WrenchDesigner(Protocol):
    """What gives a configuration's design under a wrench other than eq 31: the exact model's linearisation
    (:class:`bayescal.design.linearisation.ExactLinearisation`, which builds on this module)."""

    def wrench_design(self, q: np.ndarray, wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(3·markers, p)`` design in the relative parameters and ``(3·markers,)`` noise sd (m) of ``q`` under ``wrench``."""
        ...


def parameter_names(cell: Cell) -> list[str]:
    """``k1..k<n>`` and, with a compensator, its law's (``K_c`` and ``s0``): the cell's :class:`~bayescal.inference.parameters.ParameterRegistry`."""
    return ParameterRegistry.of_cell(cell).names


def nominal_parameters(cell: Cell) -> np.ndarray:
    """(p,) the cell's parameter values, SI: rad/(N·m), then the compensator law's (N/m and m for the spring)."""
    values = list(cell.compliances)
    if cell.compensator is not None:
        values += list(cell.compensator.values)
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
        chain[..., j2, j2] = effective[..., j2] ** 2 / k[j2] ** 2
        chain[..., j2, cell.robot.nq :] = compensator.compliance_gradient(q2, effective[..., j2])
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


def configuration_designs(cell: Cell, q: np.ndarray, wrench: np.ndarray, *, chain: BatchedChain | None = None,
                          poses: Poses | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`configuration_design` of ``N`` configurations at once, by :class:`~bayescal.robot.batched.BatchedChain`.

    Parameters
    ----------
    q
        ``(N, nq)`` joint angles, rad.
    wrench
        ``(N, 6)`` loads at the flange origin, base axes, N and N·m.
    chain
        The robot's batched chain, when already built.
    poses
        The frames of ``q`` (``chain.poses(q)``), when already computed.

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
    poses = chain.poses(q) if poses is None else poses
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


def configuration_information(cell: Cell, q, mass: float, repeats: int = 1, *, exact: WrenchDesigner | None = None) -> np.ndarray:
    """(p, p) information ``r Bᵀ W B`` of one configuration loaded with ``mass`` kg, relative parameters.

    ``exact``: take ``B`` from the exact model's linearisation instead of eq 31.
    """
    return wrench_information(cell, q, cell.load_wrench(q, mass), repeats, exact=exact)


def wrench_information(cell: Cell, q, wrench, repeats: int = 1, *, exact: WrenchDesigner | None = None) -> np.ndarray:
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


def criterion_values(
    cell: Cell, information: np.ndarray, criterion: str, *, test_design: np.ndarray | None = None, groups: np.ndarray | None = None
) -> np.ndarray:
    """:func:`~bayescal.design.prediction.criterion_value` of many information matrices at once, as the exchange algorithm needs.

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
    diagonal = np.einsum("nii->ni", information)
    if groups is None:
        labels, peak = np.zeros(n, dtype=int), diagonal.max(axis=0, keepdims=True)
    else:
        labels = np.unique(np.asarray(groups), return_inverse=True)[1].ravel()
        peak = np.zeros((labels.max() + 1, p))
        np.maximum.at(peak, labels, diagonal)
    excited = peak > UNEXCITED * np.maximum(peak.max(axis=1, initial=0.0), 1e-300)[:, np.newaxis]
    # Batches that hold the same parameters are scored together: eigh treats every matrix on its own.  The masks
    # are told apart by their bits as one whole number each (np.unique along an axis sorts a structured copy).
    keys, which = np.unique(excited @ (1 << np.arange(p)), return_inverse=True)
    masks = (keys[:, np.newaxis] >> np.arange(p)) & 1 == 1
    which = which.ravel()[labels]
    G0 = None if criterion != "test-pose" else test_pose_design(cell) if test_design is None else test_design
    values = np.empty(n)
    for m, mask in enumerate(masks):
        rows = np.flatnonzero(which == m)
        values[rows] = _criterion_values(cell, information[rows], criterion, mask, G0)
    return values


def _criterion_values(cell: Cell, information: np.ndarray, criterion: str, excited: np.ndarray, G0: np.ndarray | None) -> np.ndarray:
    """:func:`criterion_values` of matrices ``(n, p, p)`` that share the ``excited`` parameters ``(p,)``.

    Each matrix is scaled to a unit diagonal and factorised by Cholesky, 3.7 μs of NumPy's ``eigh`` a matrix
    replaced by a fifth of it (eigh was the largest share of ``bayescal plan --model linear``).  Where the factor
    cannot prove the matrix usable, :data:`DECIDED_MARGIN` clear of :data:`SINGULAR`, or fails, the eigenvalues
    decide, as before: every plan is usable or not as eigh says, and the values of the others move in their last
    digits only (the plans chosen are the same, ``benchmarks/bench_design.py``).
    """
    block = information[:, excited][:, :, excited]
    scale = 1.0 / np.sqrt(np.maximum(np.einsum("nii->ni", block), 1e-300))
    outer = scale[:, :, np.newaxis] * scale[:, np.newaxis, :]
    scaled = block * outer
    try:
        factor = np.linalg.cholesky(scaled)
    except np.linalg.LinAlgError:
        return _eigen_values(cell, scaled, scale, outer, criterion, excited, G0)
    inverse_factor = _lower_inverse(factor)
    # 1/trace of the inverse is below the smallest eigenvalue, and the largest is below the trace, p: a plan whose
    # bound clears SINGULAR by the margin is usable however the eigenvalues round.
    bound = 1.0 / np.einsum("nij,nij->n", inverse_factor, inverse_factor)
    decided = bound > DECIDED_MARGIN * SINGULAR * scale.shape[1]
    values = np.empty(len(block))
    if not decided.all():
        undecided = ~decided
        values[undecided] = _eigen_values(cell, scaled[undecided], scale[undecided], outer[undecided], criterion, excited, G0)
    inverse_factor, scale, factor = inverse_factor[decided], scale[decided], factor[decided]
    if criterion == "d-optimal":
        values[decided] = -(2.0 * np.sum(np.log(np.einsum("nii->ni", factor)), axis=1) - 2.0 * np.sum(np.log(scale), axis=1))
    elif criterion == "compensator":
        law = -len(cell.compensator.PARAMETERS)
        values[decided] = np.sum(np.sum(inverse_factor[:, :, law:] ** 2, axis=1) * scale[:, law:] ** 2, axis=1)
    else:
        whitened = inverse_factor @ (scale[:, :, np.newaxis] * G0[:, excited].T)
        values[decided] = np.sqrt(np.einsum("nij,nij->n", whitened, whitened) + _prior_term(cell, G0, excited))
    return values


def _lower_inverse(factor: np.ndarray) -> np.ndarray:
    """``(n, p, p)`` inverses of lower-triangular ``factor`` by forward substitution, a row at a time for all ``n``
    (a quarter of the time of NumPy's LU-based ``inv`` on the search's stacks of 7 × 7 matrices)."""
    p = factor.shape[-1]
    inverse = np.zeros_like(factor)
    for i in range(p):
        row = -np.einsum("nk,nkj->nj", factor[:, i, :i], inverse[:, :i, :])
        row[:, i] += 1.0
        inverse[:, i, :] = row / factor[:, i, i, np.newaxis]
    return inverse


def _eigen_values(cell: Cell, scaled, scale, outer, criterion: str, excited: np.ndarray, G0: np.ndarray | None) -> np.ndarray:
    """The criterion of unit-diagonal ``scaled`` matrices ``(n, p, p)`` from their eigenvalues (inf where unusable)."""
    values, vectors = np.linalg.eigh(scaled)
    usable = values[:, 0] > SINGULAR * values[:, -1]
    safe = np.where(usable[:, np.newaxis], values, 1.0)
    if criterion == "d-optimal":
        return np.where(usable, -(np.sum(np.log(safe), axis=1) - 2.0 * np.sum(np.log(scale), axis=1)), np.inf)
    inverse = (vectors / safe[:, np.newaxis, :]) @ vectors.transpose(0, 2, 1) * outer
    if criterion == "compensator":
        return np.where(usable, inverse[:, -2, -2] + inverse[:, -1, -1], np.inf)
    squared = np.einsum("ij,njk,ik->n", G0[:, excited], inverse, G0[:, excited])
    return np.where(usable, np.sqrt(np.maximum(squared, 0.0) + _prior_term(cell, G0, excited)), np.inf)
