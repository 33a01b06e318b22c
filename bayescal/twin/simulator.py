"""The digital twin: simulated laser-tracker campaigns of a cell with known truth.

For each configuration of a plan the twin solves the nonlinear static
equilibrium of the arm (links' weights, compensator, joint springs) twice,
without and with the load hanging at the tool's load point, places the tool's
markers at ``q + θ`` by forward kinematics, and lets the tracker read them with
fresh noise at every repeat.  Planted effects (:mod:`bayescal.twin.effects`) change
the compensator, the joint springs, add compliance outside the joints or
corrupt the readings.

:func:`design_precision` gives the precision the linear identification model
(eqs 30-37) can reach on a plan, and :func:`effect_detectability` how far a
planted effect stands above the tracker noise once the joint model has absorbed
what it can.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.twin.effects import EFFECTS, Effect
from bayescal.errors import InputError
from bayescal.cell.plan import Plan
from bayescal.reference import published
from bayescal.robot.compensator import COMPENSATED_JOINT
from bayescal.robot.stiffness import EquilibriumError, LinearJoints, compliance_design, equilibrium
from bayescal.units import MM, N_PER_MM, URAD_PER_NM

__all__ = ["DigitalTwin", "design_precision", "effect_detectability"]


class DigitalTwin:
    """A simulated calibration cell.

    Parameters
    ----------
    cell
        The cell (robot, stiffness, compensator, tool, tracker).
    effects
        Effects to plant, at most one of each kind.  The cell's compensator is on
        unless a ``compensator`` effect with magnitude 0 removes it.
    """

    def __init__(self, cell: Cell, effects: Sequence[Effect] = ()) -> None:
        names = [effect.name for effect in effects]
        for name in names:
            if names.count(name) > 1:
                raise InputError(f"effect '{name}' is given more than once", source="--effect")
        order = list(EFFECTS)
        self.cell = cell
        self.effects = tuple(sorted(effects, key=lambda effect: order.index(effect.name)))
        compensator = cell.compensator
        law = LinearJoints(cell.compliances)
        for effect in self.effects:
            compensator = effect.compensator(compensator)
            law = effect.joints(law, cell.robot)
        self.compensator = compensator
        self.joint_law = law
        self.marker_names = tuple(cell.markers)
        self._points = np.array([cell.markers[name] for name in self.marker_names])

    def _deflections(self, q, wrench) -> np.ndarray:
        return equilibrium(
            self.cell.robot,
            q,
            self.cell.compliances,
            wrench,
            compensator=self.compensator,
            gravity=True,
            load_point=self.cell.load_point,
            joints=self.joint_law,
        )

    def positions(self, q, mass: float) -> tuple[np.ndarray, np.ndarray]:
        """Exact marker positions (m, base frame, in :attr:`marker_names` order) unloaded and loaded with ``mass`` kg."""
        q = np.asarray(q, dtype=float)
        return self._positions(q, self.cell.load_wrench(q, mass))

    def _positions(self, q: np.ndarray, wrench: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        robot = self.cell.robot
        unloaded = robot.point_position(q + self._deflections(q, np.zeros(6)), self._points)
        theta = self._deflections(q, wrench)
        loaded = robot.point_position(q + theta, self._points)
        rotation, _ = robot.flange_pose(q)
        couple = wrench[3:] - np.cross(rotation @ self.cell.load_point, wrench[:3])
        for effect in self.effects:
            loaded = loaded + effect.displacement(robot, q + theta, self._points, wrench[:3], couple, self.cell.load_point)
        return unloaded, loaded

    def simulate(self, plan: Plan, repeats: int, rng: np.random.Generator) -> Campaign:
        """A campaign: every configuration of ``plan`` measured ``repeats`` times, unloaded then loaded.

        Rows are ordered by configuration, repeat and marker; each repeat reads both
        states with fresh tracker noise.  The wrench recorded is the load referred to
        the flange origin with the arm at its commanded angles.
        """
        if repeats < 1:
            raise InputError(f"expected at least 1 repeat, got {repeats}", source="--repeats")
        masses = plan.masses(self.cell.load_mass)
        n_markers = len(self.marker_names)
        rows = {"config": [], "repeat": [], "marker": [], "q": [], "wrench": [], "p0": [], "p1": []}
        for number, (q, mass, line) in enumerate(zip(plan.q, masses, plan.lines), start=1):
            wrench = self.cell.load_wrench(q, mass)
            try:
                unloaded, loaded = self._positions(q, wrench)
            except EquilibriumError as exc:
                raise InputError(f"the twin finds no static equilibrium under {mass:g} kg ({exc})", source=plan.source, line=int(line) or None) from None
            for repeat in range(1, repeats + 1):
                readings = []
                for exact in (unloaded, loaded):
                    measured = self.cell.tracker.measure(exact, rng)
                    for effect in self.effects:
                        measured = effect.corrupt(measured, rng)
                    readings.append(measured)
                rows["config"] += [number] * n_markers
                rows["repeat"] += [repeat] * n_markers
                rows["marker"] += list(self.marker_names)
                rows["q"] += [q] * n_markers
                rows["wrench"] += [wrench] * n_markers
                rows["p0"].append(readings[0])
                rows["p1"].append(readings[1])
        return Campaign(
            config=np.array(rows["config"], dtype=int),
            repeat=np.array(rows["repeat"], dtype=int),
            marker=np.array(rows["marker"], dtype=str),
            q=np.array(rows["q"], dtype=float),
            wrench=np.array(rows["wrench"], dtype=float),
            p0=np.vstack(rows["p0"]),
            p1=np.vstack(rows["p1"]),
            lines=np.zeros(len(rows["config"]), dtype=int),
            source="simulated",
        )


def _linear_model_names(cell: Cell) -> list[str]:
    names = [f"k{j}" for j in range(1, cell.robot.nq + 1)]
    return names + (["K_c", "s0"] if cell.compensator is not None else [])


def _linear_model(cell: Cell, plan: Plan, repeats: int):
    """Design of the linearised identification model, its true parameters and the noise of each equation.

    The parameters are ``k1..k6`` (rad/(N·m)) with, when the cell has a compensator,
    ``k2`` read as ``K_θ2^0`` through eq 8 and ``K_c`` (N/m) and ``s0`` (m) appended.
    """
    robot, compensator, k = cell.robot, cell.compensator, cell.compliances
    names = _linear_model_names(cell)
    truth = list(k)
    if compensator is not None:
        truth += [compensator.K_c, compensator.s0]
    blocks, sigmas, predicted = [], [], []
    j2 = COMPENSATED_JOINT
    for q, mass in zip(plan.q, plan.masses(cell.load_mass)):
        wrench = cell.load_wrench(q, mass)
        effective = k.copy()
        chain = np.eye(robot.nq, len(names))
        if compensator is not None:
            effective[j2] = 1.0 / (1.0 / k[j2] + compensator.stiffness(q[j2]))
            # K_c·a·L·η = C1·K_c + C2·s0·K_c (eq 35), so its derivatives in K_c and s0 are C1 + s0·C2 and K_c·C2.
            _, c1, c2 = compensator.regressor(q[j2])
            chain[j2, j2] = effective[j2] ** 2 / k[j2] ** 2
            chain[j2, -2] = -effective[j2] ** 2 * (c1 + compensator.s0 * c2)
            chain[j2, -1] = -effective[j2] ** 2 * compensator.K_c * c2
        designs = [compliance_design(robot, q, point, wrench) for point in cell.markers.values()]
        noise = [np.sqrt(2.0) * cell.tracker.sigma(robot.point_position(q, point)) for point in cell.markers.values()]
        # the campaign's row order: repeat, then marker
        for _ in range(repeats):
            for design, sigma in zip(designs, noise):
                blocks.append(design @ chain)
                predicted.append(design @ effective)
                sigmas.append(np.full(3, sigma))
    return names, np.array(truth), np.vstack(blocks), np.concatenate(sigmas), np.concatenate(predicted)


def _identifiable(design: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Parameters whose change by their own size moves some marker (columns scaled to a common unit)."""
    scale = np.linalg.norm(design * np.abs(truth), axis=0)
    return scale > 1e-9 * scale.max()


def design_precision(cell: Cell, plan: Plan, repeats: int = 3) -> pd.DataFrame:
    """Precision of the linearised identification (eq 37) on ``plan`` with the cell's tracker noise.

    ``cov = (Bᵀ W B)⁻¹`` with ``B`` the eq-30 design in the parameters
    ``k_j`` (``k2`` without the compensator), ``K_c`` and ``s0``, and ``W`` the inverse
    variance of each deflection coordinate (two tracker readings per deflection).
    Parameters the plan cannot excite (a zero column, e.g. ``k1`` under vertical
    loads) are reported with NaN.

    Returns
    -------
    pandas.DataFrame
        Indexed by parameter, columns ``value``, ``sd``, ``width_3sd_pct`` (3 sd as a
        percentage of the value), ``table_iv_pct`` (Klimchik et al., Table IV) and
        ``unit``, values in the paper's units (μrad/(N·m), N/mm, mm).
    """
    names, truth, design, sigma, _ = _linear_model(cell, plan, repeats)
    usable = _identifiable(design, truth)
    weighted = design[:, usable] / sigma[:, np.newaxis]
    # Scaling the columns keeps the normal matrix well conditioned across N/m and rad/(N·m).
    scale = np.abs(truth[usable])
    covariance = np.linalg.inv((weighted * scale).T @ (weighted * scale)) * np.outer(scale, scale)
    sd = np.full(len(names), np.nan)
    sd[usable] = np.sqrt(np.diag(covariance))
    unit_scale = {name: 1.0 / URAD_PER_NM for name in names if name.startswith("k")} | {"K_c": 1.0 / N_PER_MM, "s0": 1.0 / MM}
    units = {name: "urad/(N m)" for name in names if name.startswith("k")} | {"K_c": "N/mm", "s0": "mm"}
    factors = np.array([unit_scale[name] for name in names])
    return pd.DataFrame(
        {
            "value": truth * factors,
            "sd": sd * factors,
            "width_3sd_pct": 300.0 * sd / np.abs(truth),
            "table_iv_pct": [_table_iv_width_percent(name) for name in names],
            "unit": [units[name] for name in names],
        },
        index=pd.Index(names, name="parameter"),
    )


def effect_detectability(cell: Cell, plan: Plan, effect: Effect | None, *, repeats: int = 3, seed: int = 0) -> dict[str, float]:
    """How far an effect's deflections stand above the tracker noise once the joint model absorbs what it can.

    The deflections ``Δp`` of a noiseless twin with the effect are compared with
    those of the noiseless twin without it (``effect=None``: the twin without
    effects against the linear model itself, at the true parameters).  The
    difference is projected out of the linearised identification model's columns
    (a refit of the joint compliances and the compensator); what is left cannot be
    explained by the joint model.

    Returns
    -------
    dict
        ``rms_difference_um`` (RMS change of the deflection coordinates),
        ``rms_unexplained_um`` (RMS left after the refit), ``noise_sd_um`` (RMS
        standard deviation of one deflection coordinate) and ``noncentrality``:
        ``Σ r²/σ²`` over all equations, the shift it causes in the χ² of the fit
        (compare with ``sqrt(2 n)`` for ``n`` equations, the χ² spread);
        ``n_equations``; ``parameter_shift_pct``: how much the refit moves each
        identifiable parameter, in % of its value (the bias the effect causes).
    """
    _, truth, design, sigma, predicted = _linear_model(cell, plan, repeats)
    silent = replace(cell, tracker=replace(cell.tracker, factor=0.0))
    rng = np.random.default_rng(seed)
    baseline = DigitalTwin(silent).simulate(plan, repeats, rng).displacement.ravel()
    if effect is None:
        changed, reference = baseline, predicted
    else:
        changed = DigitalTwin(silent, [effect]).simulate(plan, repeats, rng).displacement.ravel()
        reference = baseline
    difference = changed - reference
    usable = _identifiable(design, truth)
    weighted = design[:, usable] * np.abs(truth[usable]) / sigma[:, np.newaxis]
    target = difference / sigma
    solution, *_ = np.linalg.lstsq(weighted, target, rcond=None)
    residual = target - weighted @ solution
    names = [name for name, keep in zip(_linear_model_names(cell), usable) if keep]
    return {
        "rms_difference_um": float(np.sqrt(np.mean(difference**2)) / 1e-6),
        "rms_unexplained_um": float(np.sqrt(np.mean((residual * sigma) ** 2)) / 1e-6),
        "noise_sd_um": float(np.sqrt(np.mean(sigma**2)) / 1e-6),
        "noncentrality": float(residual @ residual),
        "n_equations": int(len(difference)),
        "parameter_shift_pct": {name: float(100.0 * value) for name, value in zip(names, solution)},
    }


def _table_iv_width_percent(name: str) -> float:
    value, half_width = published("IV").get(name, (np.nan, np.nan))
    return 100.0 * half_width / value
