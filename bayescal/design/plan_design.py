"""A calibration plan with what it is predicted to deliver: the results of :class:`~bayescal.design.optimise.PlanDesigner`.

:class:`PlanDesign` is a plan the designer optimised (:meth:`~bayescal.design.optimise.PlanDesigner.optimise`),
:class:`PlanEvaluation` a given plan it scored (:meth:`~bayescal.design.optimise.PlanDesigner.assess`),
:class:`PlanFindings` what a plan's JSON file holds, read back.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from os import PathLike
from typing import TYPE_CHECKING

import numpy as np

from bayescal.cell.config import DEFAULT_COMPENSATED_JOINT
from bayescal.cell.plan import Plan, write_plan
from bayescal.design.prediction import criterion_value
from bayescal.design.loads import loads_json
from bayescal.design.prediction import PlanPrediction
from bayescal.inference.parameters import ANGLE_DECIMALS
from bayescal.jsonfiles import JsonFindings, JsonSchema
from bayescal.jsonsafe import json_safe
from bayescal.units import DEG, MM

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["PlanDesign", "PlanEvaluation", "PlanFindings", "PLAN_JSON"]

PLAN_JSON = JsonSchema({"criterion": (float, int, type(None)), "parameters": dict, "configurations": int}, "bayescal plan --json",
                       foreign="verdict")
"""What a reader of a plan's JSON (:meth:`PlanDesign.to_json`, :meth:`PlanEvaluation.to_json`) relies on; ``verdict`` is a
critique's key."""


@dataclass(frozen=True)
class PlanDesign:
    """An optimised plan and what it is predicted to deliver.

    Attributes
    ----------
    plan : Plan
        ``angles × per_angle`` configurations, grouped by q2, with their loads.
    criterion : str
        What was minimised (one of :data:`bayescal.design.criteria.CRITERIA`).
    prediction : PlanPrediction
        The plan's predicted precision and test-pose error with the exact model
        linearised (:class:`~bayescal.design.linearisation.ExactLinearisation`), as the
        identification's default model sees it.
    linear : PlanPrediction
        The same with eq 31's design (the paper's eqs 37-39).
    model : str
        The model the search used, ``"linear"`` or ``"exact"``.
    repeats : int
        Measurements per configuration the prediction assumes.
    starts : list of float
        The criterion reached from each random start (after refinement).
    candidates : int
        Size of the candidate set.
    seed : int or None
        The seed the optimisation ran with, when given as an integer.
    plan_joint : int
        Index (0-based) of the joint whose angles group the plan (the cell's).
    """

    plan: Plan
    criterion: str
    prediction: PlanPrediction
    linear: PlanPrediction
    model: str
    repeats: int
    starts: list[float] = field(default_factory=list)
    candidates: int = 0
    seed: int | None = None
    plan_joint: int = DEFAULT_COMPENSATED_JOINT

    def summary(self) -> pd.DataFrame:
        """Predicted precision per parameter (see :meth:`PlanPrediction.summary`)."""
        return self.prediction.summary()

    def document(self, output: str | None = None, hanging_only: bool = False):
        """The plan as one document (:mod:`bayescal.summary`): the text ``bayescal plan`` prints, and its Markdown, HTML and
        JSON; ``output`` names the file the plan was written to, ``hanging_only`` says the cell's loads only hang (k1 unbounded)."""
        from bayescal.design.document import plan_document

        return plan_document(self.to_json() | ({} if output is None else {"output": output}), self.prediction.rows(), hanging_only)

    def diagnostics(self) -> dict:
        """How the search went: the criterion reached from each start, the best of them, the candidates' count."""
        finite = [value for value in self.starts if math.isfinite(value)]
        return json_safe({
            "search_model": self.model,
            "starts": list(self.starts),
            "best_start": min(finite) if finite else math.nan,
            "candidates": self.candidates,
            "seed": self.seed,
        })

    def to_json(self) -> dict:
        """``criterion`` (ρ0, mm), the optimised criterion, the plan's angles and each parameter's ±3σ width."""
        # sorted in Python: NumPy's plain unique loads numpy.ma to test for a mask (19 ms of `plan`'s 1 s)
        q2 = sorted(set(np.round(self.plan.q[:, self.plan_joint] / DEG, ANGLE_DECIMALS).tolist()))
        return self.prediction.to_json() | {
            "model": "exact",
            "linear_model": self.linear.to_json(),
            "optimised_for": self.criterion,
            "search_model": self.model,
            "criterion_value": json_safe(criterion_value(self.prediction, self.criterion)),
            "configurations": len(self.plan),
            "repeats": self.repeats,
            "q2_deg": [float(v) for v in q2],
            **loads_json(self.plan),
            "starts": [json_safe(v) for v in self.starts],
            "candidates": self.candidates,
            "seed": self.seed,
        }

    def save(self, path: str | PathLike[str], *, comments: tuple[str, ...] = (), extra: dict[str, np.ndarray] | None = None) -> None:
        """Write the plan in the format of ``data/table3_plan.csv``, with ``extra`` integer columns after its own."""
        rho0 = self.prediction.rho0
        note = (
            f"predicted rms error at the test pose after compensation {rho0 / MM:.5f} mm, everything counted "
            f"({self.prediction.rho0_identified / MM:.5f} mm from the plan's data alone)"
            if math.isfinite(rho0)
            else ""
        )
        write_plan(self.plan, path, comments=(f"plan optimised for the {self.criterion} criterion, {self.repeats} repeats; {note}",) + tuple(comments),
                   extra=extra)


@dataclass(frozen=True)
class PlanEvaluation:
    """A given plan scored: its predicted precision and test-pose error, and the configurations that break a constraint.

    Attributes
    ----------
    plan : Plan
        The plan scored.
    prediction, linear : PlanPrediction
        As :class:`PlanDesign`'s: with the exact model linearised, and with eq 31's design.
    repeats : int
        Measurements per configuration the prediction assumes.
    violations : list of dict
        ``{"config": number (from 1), "reason": text}`` of each configuration the cell cannot measure.
    source : str
        Where the plan was read from.
    """

    plan: Plan
    prediction: PlanPrediction
    linear: PlanPrediction
    repeats: int
    violations: list[dict] = field(default_factory=list)
    source: str = ""

    def summary(self) -> pd.DataFrame:
        """Predicted precision per parameter (see :meth:`PlanPrediction.summary`)."""
        return self.prediction.summary()

    def document(self, hanging_only: bool = False):
        """The assessment as one document (:mod:`bayescal.summary`): the text ``bayescal plan --evaluate`` prints, and its
        Markdown, HTML and JSON; ``hanging_only`` says the cell's loads only hang (k1 unbounded by any plan)."""
        from bayescal.design.document import plan_document

        return plan_document(self.to_json(), self.prediction.rows(), hanging_only)

    def diagnostics(self) -> dict:
        """The plan's size and the configurations that break a constraint of the cell."""
        return {"configurations": len(self.plan), "repeats": self.repeats, "violations": list(self.violations)}

    def to_json(self) -> dict:
        """``criterion`` (ρ0, mm) and each parameter's ±3σ width with both models, and the violations."""
        return self.prediction.to_json() | {
            "model": "exact",
            "linear_model": self.linear.to_json(),
            "plan": self.source,
            "configurations": len(self.plan),
            "repeats": self.repeats,
            "violations": list(self.violations),
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to a JSON file."""
        with open(path, "w", encoding="utf-8") as out:
            json.dump(self.to_json(), out, indent=2, allow_nan=False)


@dataclass(frozen=True)
class PlanFindings(JsonFindings):
    """What a plan's JSON file (:meth:`PlanDesign.to_json`, :meth:`PlanEvaluation.to_json`) holds.

    Attributes
    ----------
    criterion : float or None
        ρ0 predicted at the test pose, in ``criterion_unit`` (mm rms), everything counted.
    parameters : dict
        Parameter -> ``value``, ``width_3sd``, ``width_3sd_pct``, ``excited`` and ``unit`` (the parameter's).
    configurations : int
    criterion_unit, criterion_includes : str or None
    criterion_identified_only : float or None
        ρ0 from the plan's data alone (``criterion_unit``).
    criterion_prior_share_of_mean_square : float or None
        The prior's share of ρ0's mean square, in [0, 1].
    linear_model : dict or None
        The same prediction by the linear model of eq 31 (``criterion``, in ``criterion_unit``).
    optimised_for, search_model : str or None
        The criterion the plan was designed for and the model the search used.
    repeats : int or None
    q2_deg, load_kg : list or None
        The plan's q2 angles (deg) and hanging loads (kg).
    starts : list or None
        The optimised criterion each random start reached (SI: m for the test-pose criterion).
    candidates : int or None
        Candidate configurations of the search.
    keys : tuple of str
        The file's keys in its order (a key held as null apart from one missing).
    extra : dict
        The file's other keys, as they came.
    """

    criterion: float | None
    parameters: dict
    configurations: int
    criterion_unit: str | None = None
    criterion_includes: str | None = None
    criterion_identified_only: float | None = None
    criterion_prior_share_of_mean_square: float | None = None
    linear_model: dict | None = None
    optimised_for: str | None = None
    search_model: str | None = None
    repeats: int | None = None
    q2_deg: list | None = None
    load_kg: list | None = None
    starts: list | None = None
    candidates: int | None = None
    keys: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)

    SCHEMA = PLAN_JSON
    OPTION = "--plan"
    NAME = "the plan's JSON"
