"""The loads a designed plan applies: hanging masses, or forces and couples in any direction (eq 41).

A load is a (6,) vector ``[f; c]``: the force through the tool's load point (N)
and the couple (N·m), both in base axes (:meth:`~bayescal.cell.config.Cell.wrench`
refers it to the flange origin).  On a cell whose end-effector hangs masses
only, every configuration carries the heaviest mass of the design's range: a
configuration's information grows as its load squared.  On a cell whose
end-effector pushes or pulls in any direction (``[load] directions = "any"``),
every configuration carries a force of ``F_max`` (eq 41) and, when the
end-effector applies couples, a couple of ``couple_max_Nm``, in directions the
design chooses (eq 40 minimises over the loadings as well as the configurations).

The candidate set offers each feasible configuration under
:data:`DIRECTIONS_PER_CONFIGURATION` loads: the first straight down, the
others in directions uniform on the sphere.  Their information comes from a
basis: the design (exact or eq 31) under a force of ``F_max`` along each base
axis, and a couple along each, computed once per configuration; a load's design
is their combination.  Deflections are linear in the load to first order
(eq 31); the exact model's departure is measured in ``tests/design/test_loads.py``.
The refinement turns the directions and scores every proposal with the model
under the load itself, as the final prediction does.
"""

from __future__ import annotations

import numpy as np

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.design.criteria import configuration_design, configuration_designs
from bayescal.design.linearisation import ExactLinearisation
from bayescal.robot.stiffness import EquilibriumError

__all__ = [
    "DIRECTIONS_PER_CONFIGURATION",
    "basis_designs",
    "combined_information",
    "draw_loads",
    "free_candidates",
    "load_sizes",
    "loads_json",
    "turn_draws",
    "turned",
]

DIRECTIONS_PER_CONFIGURATION = 8
"""Loads offered per candidate configuration on an any-direction cell: straight down and 7 random directions
(with the refinement's turns, enough that the designed plans' loads spread over the sphere)."""


def load_sizes(cell: Cell, heaviest_mass: float) -> tuple[float, float]:
    """``(force, couple)`` sizes (N, N·m) of a designed plan's loads: the heaviest mass's weight on a
    hanging-only cell (capped by ``force_max_N`` when given), else ``F_max`` and ``couple_max_Nm``."""
    loading = cell.loading
    if loading.hanging_only:
        weight = heaviest_mass * cell.gravity
        return (weight if loading.force_max is None else min(weight, loading.force_max)), 0.0
    return float(loading.force_max), float(loading.couple_max)


def _unit_vectors(count: int, rng: np.random.Generator) -> np.ndarray:
    vectors = rng.normal(size=(count, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def draw_loads(count: int, force: float, couple: float, rng: np.random.Generator) -> np.ndarray:
    """(count, 6) loads: the first a force straight down, the others uniform in direction; couples uniform too."""
    directions = _unit_vectors(count, rng)
    directions[0] = [0.0, 0.0, -1.0]
    couples = _unit_vectors(count, rng) * couple
    return np.hstack([directions * force, couples])


def turn_draws(sizes: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """(2, 3) the normal draws of one :func:`turned` step of a load whose force and couple have ``sizes`` (N, N·m):
    three for each part that is not zero, in that order (a zero part draws nothing and keeps zeros)."""
    draws = np.zeros((2, 3))
    for part, size in enumerate(sizes):
        if size > 0:
            draws[part] = rng.normal(size=3)
    return draws


def turned(load: np.ndarray, angle: float, draws: np.ndarray) -> np.ndarray:
    """``load`` with its force and couple turned by random steps of about ``angle`` rad (``draws`` from
    :func:`turn_draws`), sizes kept."""
    out = load.copy()
    for k, part in enumerate((slice(0, 3), slice(3, 6))):
        size = np.linalg.norm(load[part])
        if size > 0:
            moved = load[part] / size + draws[k] * angle
            out[part] = moved / np.linalg.norm(moved) * size
    return out


def basis_designs(cell: Cell, q, force: float, couple: float, exact: ExactLinearisation | None) -> tuple[np.ndarray, np.ndarray]:
    """The designs of configuration ``q`` under the basis loads.

    Returns
    -------
    basis : numpy.ndarray
        (k, rows, p) derivatives of the deflections (m) in the relative parameters under a force of
        ``force`` N along base x, y, z, then (when ``couple`` > 0) a couple of ``couple`` N·m along each.
    sigma : numpy.ndarray
        (rows,) deflection noise (m) under the load straight down.

    Raises :class:`~bayescal.robot.stiffness.EquilibriumError` when a basis load has no equilibrium.
    """
    loads = [np.concatenate([axis * force, np.zeros(3)]) for axis in np.eye(3)]
    loads += [np.concatenate([np.zeros(3), axis * couple]) for axis in np.eye(3)] if couple > 0 else []
    designs = []
    for load in loads:
        wrench = cell.wrench(q, load[:3], load[3:])
        designs.append(configuration_design(cell, q, wrench)[0] if exact is None else exact.wrench_design(q, wrench)[0])
    down = cell.wrench(q, [0.0, 0.0, -force])
    sigma = configuration_design(cell, q, down)[1] if exact is None else exact.wrench_design(q, down)[1]
    return np.array(designs), sigma


def combined_information(basis: np.ndarray, sigma: np.ndarray, loads: np.ndarray, force: float, couple: float, repeats: int) -> np.ndarray:
    """(n, p, p) information of one configuration under each of ``loads`` (n, 6), from its :func:`basis_designs`."""
    weights = loads[:, :3] / force
    if couple > 0:
        weights = np.hstack([weights, loads[:, 3:] / couple])
    designs = np.einsum("nk,krp->nrp", weights, basis) / sigma[np.newaxis, :, np.newaxis]
    return repeats * np.einsum("nri,nrj->nij", designs, designs)


def free_candidates(
    cell: Cell,
    configurations: np.ndarray,
    index: np.ndarray,
    rng: np.random.Generator,
    force: float,
    couple: float,
    exact: ExactLinearisation | None,
    repeats: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each of ``configurations`` (n, nq) under :data:`DIRECTIONS_PER_CONFIGURATION` loads of the given sizes.

    Returns the repeated configurations, their grid ``index``, their (m, p, p) information
    (``repeats`` measurements) and their (m, 6) loads; a configuration whose basis load
    finds no equilibrium is dropped.
    """
    kept, information, loads = [], [], []
    bases = _all_basis_designs(cell, configurations, force, couple, exact)
    for row, q in enumerate(configurations):
        try:
            basis, sigma = bases[row] if bases is not None else basis_designs(cell, q, force, couple, exact)
        except EquilibriumError:
            continue
        drawn = draw_loads(DIRECTIONS_PER_CONFIGURATION, force, couple, rng)
        kept += [row] * len(drawn)
        information.append(combined_information(basis, sigma, drawn, force, couple, repeats))
        loads.append(drawn)
    kept = np.array(kept, dtype=int)
    return configurations[kept], index[kept], np.concatenate(information), np.concatenate(loads)


def _all_basis_designs(cell: Cell, configurations: np.ndarray, force: float, couple: float, exact: ExactLinearisation | None):
    """:func:`basis_designs` of every configuration ``(n, nq)``, solved at once; None when one has no equilibrium
    (the caller then finds it one configuration at a time)."""
    loads = [np.concatenate([axis * force, np.zeros(3)]) for axis in np.eye(3)]
    loads += [np.concatenate([np.zeros(3), axis * couple]) for axis in np.eye(3)] if couple > 0 else []
    loads.append(np.array([0.0, 0.0, -force, 0.0, 0.0, 0.0]))
    n = len(configurations)
    q = np.tile(configurations, (len(loads), 1))
    wrench = np.array([cell.wrench(qi, load[:3], load[3:]) for load in loads for qi in configurations])
    try:
        design, sigma = configuration_designs(cell, q, wrench) if exact is None else exact.wrench_designs(q, wrench)
    except EquilibriumError:
        return None
    design = design.reshape(len(loads), n, *design.shape[1:])
    sigma = sigma.reshape(len(loads), n, -1)
    return [(design[:-1, row], sigma[-1, row]) for row in range(n)]


def loads_json(plan: Plan) -> dict:
    """The plan's loads: its masses (kg), or the largest force (N) and couple (N·m) of a plan with forces."""
    if plan.force is None:
        return {"load_kg": sorted({float(m) for m in plan.masses(0.0)})}
    return {"force_max_N": float(np.linalg.norm(plan.force, axis=1).max()), "couple_max_Nm": float(np.linalg.norm(plan.couples(), axis=1).max())}
