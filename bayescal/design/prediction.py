"""What a plan's information matrix predicts: the covariance, the error left at the test pose (eq 39) and ``log det``.

:func:`predict` inverts the information matrix of :mod:`bayescal.design.criteria`
over the parameters the plan excites and returns a :class:`PlanPrediction`,
whose ``rho0`` adds the priors of the compliances the plan does not excite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from typing import TYPE_CHECKING

import numpy as np

from bayescal.cell.config import Cell
from bayescal.design.criteria import (
    CRITERIA,
    SINGULAR,
    UNEXCITED,
    _prior_term,
    nominal_parameters,
    parameter_names,
    test_pose_design,
)
from bayescal.inference.parameters import ParameterRegistry
from bayescal.jsonsafe import json_safe
from bayescal.units import MM

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["PlanPrediction", "criterion_value", "predict"]


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
        import pandas as pd

        return pd.DataFrame(self._columns(), index=pd.Index(self.names, name="parameter"))

    def rows(self) -> list[tuple[str, dict]]:
        """:meth:`summary`'s rows without pandas: each parameter's name and its row (floats and the unit's text)."""
        columns = {name: list(values) if isinstance(values, list) else values.tolist() for name, values in self._columns().items()}
        return [(name, {column: values[i] for column, values in columns.items()}) for i, name in enumerate(self.names)]

    def _columns(self) -> dict:
        """:meth:`summary`'s columns by name: arrays of floats, and lists of the published widths and the units."""
        parameters = [self.registry[name] for name in self.names]
        factors = np.array([1.0 / p.si_factor for p in parameters])
        sd = self.relative_sd * np.abs(self.nominal)
        columns = {"value": self.nominal * factors, "sd": sd * factors, "width_3sd_pct": 300.0 * self.relative_sd}
        if self.registry.published is not None:
            columns["table_iv_pct"] = [100.0 * p.published[1] / p.published[0] if p.published else math.nan for p in parameters]
        columns["unit"] = [p.unit for p in parameters]
        return columns

    def to_json(self) -> dict:
        """``criterion`` (ρ0 in mm, null when not predictable) and each parameter's ±3σ width."""
        rows = self.rows()
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
                    "value": float(row["value"]),
                    "unit": row["unit"],
                    "sd": json_safe(row["sd"]),
                    "width_3sd": json_safe(3.0 * row["sd"]),
                    "width_3sd_pct": json_safe(row["width_3sd_pct"]),
                    "excited": bool(excited),
                }
                for (name, row), excited in zip(rows, self.excited)
            },
        }


def predict(cell: Cell, information: np.ndarray, *, test_design: np.ndarray | None = None) -> PlanPrediction:
    """The covariance, ``ρ0`` and ``log det`` a plan's information matrix gives.

    Parameters
    ----------
    cell
        The cell (nominal parameters, test pose).
    information
        (p, p) sum of :func:`~bayescal.design.criteria.configuration_information` over the plan.
    test_design
        (3, p) :func:`~bayescal.design.criteria.test_pose_design` of ``cell``, when already computed.
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
    the compensator law's parameters; ``d-optimal``: ``-log det`` of the information matrix.
    """
    if criterion == "test-pose":
        return prediction.rho0
    if criterion == "compensator":
        if not prediction.registry.compensated:
            raise ValueError("the compensator criterion needs a cell with a compensator")
        variance = np.diag(prediction.covariance)[-len(prediction.registry.law_names) :]
        return float(np.sum(variance)) if np.all(np.isfinite(variance)) else math.inf
    if criterion == "d-optimal":
        return -prediction.log_det
    raise ValueError(f"unknown criterion {criterion!r}; expected one of {', '.join(CRITERIA)}")
