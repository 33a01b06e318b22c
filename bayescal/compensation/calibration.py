"""A saved elastostatic calibration as the compensation uses it: posterior draws of the arm's parameters.

``bayescal calibrate --posterior`` writes the posterior DataTree; the
compensation needs, draw by draw, each joint's own compliance, the compensator
law's parameters (the spring's ``K_c``, ``s0``), its geometry and the scale of the link masses,
without the campaign.  A joint compliance the campaign could not identify (k1
under hanging loads) is not in the posterior: its draws come from its prior,
log-normal with the cell's value as median and the cell's ``[joints] k_log_sd``
(:attr:`~bayescal.cell.config.Cell.compliance_log_sd`), so that its uncertainty
reaches every predicted error instead of a fixed guess.  Those draws are the
prior's quantiles, not random numbers, so that every command (calibrate,
compensate, the review) spreads the same draws and prints the same numbers.
The law's parameters are always sampled; when flagged not identifiable their
draws are essentially their prior's.

The correction applies the **median** of the draws of each parameter (for a
parameter drawn from its prior, the cell's value), the estimate a user expects;
the error bounds carry the spread about it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike

import numpy as np

from bayescal.cell.config import Cell
from bayescal.errors import InputError
from bayescal.inference.parameters import GEOMETRY_PARAMETERS, ParameterRegistry
from bayescal.robot.compensator import Compensator, law_on
from bayescal.robot.kinds import LAWS
from bayescal.robot.laws import CompensatorLaw
from bayescal.units import DEG

__all__ = ["Calibration", "check_calibration_robot", "load_calibration", "calibration_from_tree", "prior_draws", "GRID_STEP", "MAX_DRAWS"]

MAX_DRAWS = 2000
"""Posterior draws kept (evenly thinned): the cost of the spread is linear in them, and 2000 draws
leave about 5 beyond the 99.73 % quantile."""

GRID_STEP = 0.25 * DEG
"""Knot spacing (rad) of the compensated joint's equivalent compliance when a program has many distinct angles."""


def prior_draws(median: float, log_sd: float, size: int, joint: int) -> np.ndarray:
    """``(size,)`` draws of a log-normal prior: its quantiles at ``(i + ½)/size``, in an order fixed by ``joint``.

    Quantiles rather than random numbers: the draws' median is ``median`` exactly, their spread is the
    prior's without sampling noise, and every command that reads a calibration gets the same draws.  The
    order (a permutation seeded by the 0-based joint index) pairs them with the posterior draws of the
    other parameters independently of any draw order.
    """
    from scipy.special import ndtri

    z = ndtri((np.arange(size) + 0.5) / size)
    return median * np.exp(log_sd * np.random.default_rng(joint).permutation(z))


@dataclass(frozen=True)
class Calibration:
    """Posterior draws of the parameters the compensation needs (SI), ``S`` draws.

    Attributes
    ----------
    own : numpy.ndarray
        ``(S, n)`` joint compliances, rad/(N·m); the compensated joint's excludes its compensator.
    spring : numpy.ndarray or None
        ``(S, p)`` the compensator law's parameters in SI (``K_c`` N/m and ``s0`` m for the spring); None
        without a compensator.
    geometry : numpy.ndarray or None
        ``(S, 4)`` ``L, a_x, a_y`` (m), ``phi`` (rad) of the compensator.
    gravity_scale : float
        Posterior mean of the scale on the link masses (1 when not sampled).
    compensated_joint : int or None
        0-based index of the joint with the compensator.
    unidentified : tuple of str
        Parameters the campaign did not identify, whose draws are (mostly) their prior's.
    source : str
        The posterior file.
    priors : dict
        For each compliance drawn from its log-normal prior: ``{"median", "unit"}`` (the cell's value in
        the registry's edge unit), ``"log_sd"`` and its ``"source"`` (the cell file's key or the default).
    law : CompensatorLaw or None
        The cell's compensator (its law and constants); None: the spring of eqs 4-9.
    """

    own: np.ndarray
    spring: np.ndarray | None
    geometry: np.ndarray | None
    gravity_scale: float
    compensated_joint: int | None
    unidentified: tuple[str, ...]
    source: str = ""
    priors: dict = field(default_factory=dict)
    law: CompensatorLaw | None = None

    @property
    def n_draws(self) -> int:
        return self.own.shape[0]

    @property
    def applied_own(self) -> np.ndarray:
        """``(n,)`` the joint compliances the correction applies: the draws' median (rad/(N·m))."""
        return np.median(self.own, axis=0)

    def median_compensator(self) -> CompensatorLaw | None:
        """The compensator at the median of its geometry and law's draws (what the correction applies)."""
        if self.spring is None:
            return None
        return law_on(self.law, np.median(self.geometry, axis=0), np.median(self.spring, axis=0))

    def compliances(
        self, q_compensated: np.ndarray, *, fixed: tuple[str, ...] = ()
    ) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None]:
        """Joint compliances (rad/(N·m)) draw by draw: the constant ones and the compensated joint's, pose by pose.

        Parameters
        ----------
        q_compensated
            ``(P,)`` angles of the compensated joint the program visits, rad (ignored without a compensator).
        fixed
            Parameter names (``k1``.., the law's ``K_c``, ``s0``) held at their median, the value the
            correction applies: how much of the error they account for is the difference with
            the full spread.

        Returns
        -------
        tuple
            ``(S, n)`` compliances (the compensated joint's own, without its compensator), and
            a function giving the ``(p, S)`` equivalent compliance of the compensated joint (eq 8)
            at ``p`` of those angles (None without a compensator).
        """
        own = self.own.copy()
        for j in range(own.shape[1]):
            if f"k{j + 1}" in fixed:
                own[:, j] = np.median(own[:, j])
        if self.spring is None:
            return own, None
        spring = self.spring.copy()
        for i, name in enumerate(self._law_names):
            if name in fixed:
                spring[:, i] = np.median(spring[:, i])
        return own, self._equivalent(np.asarray(q_compensated, dtype=float), own[:, self.compensated_joint], spring)

    @property
    def _law_names(self) -> list[str]:
        """The compensator law's parameters' names (``K_c``, ``s0`` for the spring)."""
        return [p.name for p in (self.law or Compensator).PARAMETERS]

    def _equivalent(self, q: np.ndarray, own: np.ndarray, spring: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """The compensated joint's equivalent compliance ``1/(1/own + dM_c/dq(q))`` (eq 8), draw by draw.

        Evaluated once at the distinct angles of ``q``, or, when there are more of them than
        knots of a :data:`GRID_STEP` grid over their range, on that grid; the returned function
        gives ``(p, S)`` values at ``p`` of these angles (interpolated linearly on the grid).
        """
        distinct = np.unique(q)
        grid = np.arange(distinct[0], distinct[-1] + GRID_STEP, GRID_STEP)
        exact = distinct.size <= grid.size
        knots = distinct if exact else grid
        law = law_on(self.law, self.geometry[0], spring[0])
        stiffness = law.joint_stiffness_of(knots, self.geometry, np.column_stack([1.0 / own, spring]))
        # Knots by rows: a pose's draws are then contiguous, as the spread wants them.
        values = np.ascontiguousarray((1.0 / stiffness).T)

        def at(angles: np.ndarray) -> np.ndarray:
            if exact:
                return values[np.searchsorted(knots, angles)]
            i = np.clip(np.searchsorted(knots, angles) - 1, 0, knots.size - 2)
            t = ((angles - knots[i]) / GRID_STEP)[:, None]
            return values[i] * (1.0 - t) + values[i + 1] * t

        return at


def load_calibration(path: str | PathLike[str], cell: Cell) -> Calibration:
    """Read the posterior ``bayescal calibrate --posterior`` wrote, for ``cell``'s robot.

    Parameters
    ----------
    path
        The NetCDF posterior.
    cell
        The cell it must belong to: same joint count and, when the file records it, same robot;
        its priors give the draws of the joint compliances the calibration did not identify.

    Raises
    ------
    InputError
        When the file is not an elastostatic posterior, belongs to another robot or joint
        count, or lacks the compensator model the cell needs.
    """
    from bayescal.sampling.summary import read_posterior

    tree, _ = read_posterior(path)
    return calibration_from_tree(tree, cell, str(path))


def calibration_from_tree(tree, cell: Cell, source: str = "the calibration") -> Calibration:
    """The :class:`Calibration` of a posterior DataTree: a saved one or :attr:`ElastostaticResults.tree` in memory.

    Both give the same draws, so that ``calibrate`` and ``compensate`` print the same numbers.
    """
    posterior = tree["posterior"]
    # A robot without a compensator has no per-angle compliances: any joint compliance tells the kind.
    if "sigma" not in posterior or not any(name[:1] == "k" and name[1:].isdigit() for name in posterior.data_vars):
        raise InputError("not an elastostatic posterior (no joint compliance k<j> or no 'sigma'): expected `bayescal calibrate --posterior`", source=source)
    n = cell.robot.nq
    check_calibration_robot(tree, cell, source)

    def values(name: str, thin: bool = True) -> np.ndarray:
        flat = np.asarray(posterior[name].transpose("chain", "draw", ...).values, dtype=float).reshape(-1)
        return flat[keep] if thin else flat

    total = values("sigma", thin=False).size // max(posterior["sigma"].sizes.get("noise_group", 1), 1)
    keep = np.linspace(0, total - 1, min(total, MAX_DRAWS)).round().astype(int)
    size = keep.size
    joint = cell.compensated_joint
    registry = ParameterRegistry.of_cell(cell)
    own = np.empty((size, n))
    unidentified = {name for name in str(tree.attrs.get("not_identifiable", "")).split(",") if name}
    priors = {}
    for j in range(n):
        name = f"k{j + 1}"
        if name in posterior:
            own[:, j] = registry[name].to_si(values(name))
        else:
            own[:, j] = prior_draws(cell.compliances[j], cell.compliance_log_sd, size, j)
            unidentified.add(name)
            priors[name] = {
                "median": float(registry[name].to_edge(cell.compliances[j])),
                "unit": registry[name].unit,
                "log_sd": cell.compliance_log_sd,
                "source": cell.compliance_log_sd_source,
            }
    spring, geometry = _compensator_draws(posterior, values, cell, registry, size, source)
    gravity = float(values("gravity_scale").mean()) if "gravity_scale" in posterior else 1.0
    names = [f"k{j + 1}" for j in range(n)] + registry.law_names
    return Calibration(
        own=own,
        spring=spring,
        geometry=geometry,
        gravity_scale=gravity,
        compensated_joint=joint,
        unidentified=tuple(name for name in names if name in unidentified),
        source=source,
        priors=priors,
        law=cell.compensator,
    )


def _compensator_draws(posterior, values, cell: Cell, registry, size: int, source: str) -> tuple[np.ndarray | None, np.ndarray | None]:
    """``(S, p)`` the law's draws (the spring's ``K_c, s0``) and ``(S, 4)`` its geometry's (the cell's where the posterior
    has none), SI; ``None, None`` for a cell without a compensator, refusing a calibration whose compensator is not the cell's."""
    names = registry.law_names
    if cell.compensated_joint is not None:
        if not all(name in posterior for name in names):
            raise InputError(
                f"the calibration has no compensator model ({', '.join(names)}: its campaign had fewer than three joint-2 "
                "angles, or its compensator is of another kind); the cell's compensated joint cannot be predicted at other angles",
                source=source,
            )
        spring = np.column_stack([registry[name].to_si(values(name)) for name in names])
        if "L" in posterior:
            geometry = np.column_stack([p.to_si(values(p.name)) for p in GEOMETRY_PARAMETERS])
        else:
            c = cell.compensator
            geometry = np.tile([c.L, c.a_x, c.a_y, c.phi], (size, 1))
        return spring, geometry
    if any(name in posterior for law in LAWS.values() for name in (p.name for p in law.PARAMETERS)):
        raise InputError(
            f"the calibration has a compensator and the cell ({cell.source}) has none: it belongs to another cell",
            source=source,
        )
    return None, None


def check_calibration_robot(tree, cell: Cell, source: str) -> None:
    """Refuse a saved elastostatic posterior of another robot than ``cell``'s: another joint count, or another
    robot name when the file records it (an :class:`~bayescal.errors.InputError` naming ``source``)."""
    attrs, posterior = tree.attrs, tree["posterior"]
    n = cell.robot.nq
    sampled = [int(name[1:]) for name in posterior.data_vars if name[:1] == "k" and name[1:].isdigit()]
    # Files written before the joint count was recorded show it only by their highest sampled joint.
    joints = max(int(attrs.get("n_joints", 0)), max(sampled, default=0))
    if joints > n or ("n_joints" in attrs and joints != n):
        raise InputError(
            f"the calibration is of a robot with {joints} joints, the cell's ({cell.source}) has {n}: it belongs to another cell",
            source=source,
        )
    robot = attrs.get("robot")
    if robot is not None and str(robot) != cell.robot.model.name:
        raise InputError(f"the calibration is of robot '{robot}', the cell's ({cell.source}) is '{cell.robot.model.name}'", source=source)
