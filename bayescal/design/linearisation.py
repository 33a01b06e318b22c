"""The exact model linearised about a cell's values: the designs eq 31 leaves out the arm's geometry from.

:class:`ExactLinearisation` takes the design of a configuration from the twin's
loaded equilibrium (the links' weights and the compensator) by central
differences in the relative parameters of :mod:`bayescal.design.criteria`;
:func:`test_deflection` is the exact deflection at the cell's test pose.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayescal.cell.config import Cell
from bayescal.design.criteria import nominal_parameters
from bayescal.robot.batched import BatchedChain, equilibria
from bayescal.robot.stiffness import ElasticArm

__all__ = ["DIFFERENCE_STEP", "ExactLinearisation", "solve_equilibrium", "test_deflection", "with_parameters"]


DIFFERENCE_STEP = 1e-4
"""Relative step of the exact model's central differences: deflections are nearly linear in the
parameters, so the truncation error (order step², relative) stays far below the solves' rounding."""


def with_parameters(cell: Cell, theta: np.ndarray) -> Cell:
    """``cell`` with the parameters ``theta`` = [k1..k<n>, *law values] (SI; ``K_c``, ``s0`` for the spring)."""
    nq = cell.robot.nq
    compensator = cell.compensator
    if compensator is not None:
        compensator = replace(compensator, **{p.name: float(v) for p, v in zip(compensator.PARAMETERS, theta[nq:])})
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
    its law's parameters (``K_c`` and ``s0``) act on the deflections also through the arm's geometry,
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
        self._springs = None if cell.compensator is None else np.array([v.compensator.values for v in variants])

    def deflections(self, q, mass: float) -> np.ndarray:
        """(markers, 3) noiseless deflections (m) at the cell's values."""
        return self.wrench_deflections(q, self.cell.load_wrench(q, mass))

    def wrench_deflections(self, q, wrench) -> np.ndarray:
        """(markers, 3) noiseless deflections (m) at the cell's values under any (6,) ``wrench`` (flange origin, base axes)."""
        unloaded, loaded = self._positions(np.asarray(q, dtype=float)[np.newaxis], np.asarray(wrench, dtype=float)[np.newaxis], nominal_only=True)
        return (loaded - unloaded)[0, 0]

    def configuration_design(self, q, mass: float) -> tuple[np.ndarray, np.ndarray]:
        """Like :func:`~bayescal.design.criteria.configuration_design`, from the exact model; the noise is that of the two readings."""
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
