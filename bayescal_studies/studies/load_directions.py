"""What loads in any direction buy over hanging masses: the error left at the test pose, and k1.

Klimchik et al. warn that "the direction of the external loading should not be
the same for all experiments (in spite of the fact that the gravity-based
loading is the most attractive from the practical point of view)", and their
eq 40 optimises over the loadings too.  Hanging masses never turn A1, so k1
stays at the config's value and its error passes, unseen, into the test pose's
compensation, where a machining wrench has horizontal components.

The study compares three plans of the same size on a cell whose end-effector
applies forces in any direction up to ``F_max`` (eq 41):

* ``hanging, test-pose optimal``: the best plan of hanging masses
  (:class:`~bayescal.design.optimise.PlanDesigner` on the same cell restricted to
  ``directions = "down"``, the heaviest mass of the design's range);
* ``hanging + sideways``: that plan with a few of its loads turned horizontal,
  the same size of force, each across the radius from the A1 axis so that it
  turns A1 hardest;
* ``free directions, test-pose optimal``: the plan designed over the
  configurations and the load directions.

Each is measured on the twin over the same simulated campaigns
(:mod:`bayescal_studies.studies.plans`: truths drawn about the cell's values, every
parameter including k1 drawn, tracker noise, the linear-Gaussian closed-form
estimate) and scored by the error left at the test pose.  For k1 the study
also counts how often the ±3σ interval of the estimate covers the truth, and
asks the identification's own structural analysis
(:meth:`~bayescal.inference.elastostatic.ElastostaticModel.estimate`) on one
campaign per plan whether k1 is reported identifiable.  With ``k1_known`` every
truth keeps the config's k1, which shows what the plans deliver apart from k1.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from concurrent.futures import Executor
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.loading import Loading
from bayescal.cell.plan import Plan
from bayescal.design.prediction import predict
from bayescal.design.optimise import PlanDesigner
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal_studies.studies.plans import CampaignModel, simulate_plan
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import UM, URAD_PER_NM

__all__ = ["LoadDirectionFindings", "load_direction_study", "sideways"]


def sideways(cell: Cell, plan: Plan, count: int) -> Plan:
    """``plan`` (hanging masses) with the loads of its ``count`` configurations farthest from the A1 axis turned horizontal.

    Each turned force keeps its size and points across the radius from the A1 axis to the load
    point, the direction that turns A1 hardest; the others stay hanging.
    """
    forces = plan.forces(cell.load_mass, cell.gravity)
    points = np.array([cell.robot.point_position(q, cell.load_point) for q in plan.q])
    radius = np.hypot(points[:, 0], points[:, 1])
    turned = np.argsort(radius)[::-1][:count]
    for row in turned:
        across = np.array([-points[row, 1], points[row, 0], 0.0]) / radius[row]
        forces[row] = across * np.linalg.norm(forces[row])
    return dataclasses.replace(plan, load_kg=None, force=forces, source=f"{plan.source}, {count} loads turned sideways")


@dataclasses.dataclass(frozen=True)
class LoadDirectionFindings:
    """Result of :func:`load_direction_study`.

    Attributes
    ----------
    scores : pandas.DataFrame
        Indexed by plan: ``predicted_rho0_um`` (eq 39, exact linearisation, with k1's prior where the
        plan holds it: :mod:`bayescal.design.criteria`), ``predicted_rho0_identified_um`` (the plan's data
        alone: k1 held at the cell's value), ``mean_error_um`` and ``mean_error_se_um`` (length of
        the error left at the test pose over the campaigns), ``rms_error_um``,
        ``difference_to_hanging_um`` and ``difference_se_um`` (mean error minus the hanging plan's,
        paired over the same campaigns), ``k1_excited``, ``k1_identifiable`` (the identification's
        report on one campaign), ``k1_width_3sd_pct`` (predicted), ``k1_coverage_3sd`` (share of
        campaigns whose ±3σ interval of k1 covers the truth; NaN where k1 is held), ``campaigns``.
    plans : dict of str to Plan
    settings : dict
        The study's arguments.
    """

    scores: pd.DataFrame
    plans: dict[str, Plan]
    settings: dict

    def summary(self) -> pd.DataFrame:
        """:attr:`scores`."""
        return self.scores

    def diagnostics(self) -> dict:
        """The free-direction plan's gain over the hanging one, in standard errors, and k1's coverage."""
        free, hanging = self.scores.iloc[-1], self.scores.iloc[0]
        return {
            "gain_um": float(hanging.mean_error_um - free.mean_error_um),
            "gain_in_se": float(-free.difference_to_hanging_um / free.difference_se_um),
            "k1_coverage_3sd": float(free.k1_coverage_3sd),
        }

    def to_json(self) -> dict:
        """Scores per plan (NaN as null), diagnostics and settings."""
        table = self.scores.astype(object).where(self.scores.notna(), None)
        return {"scores": table.to_dict(orient="index"), "diagnostics": self.diagnostics(), "settings": self.settings}

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to ``path``."""
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n", encoding="utf-8")


def load_direction_study(
    cell: Cell,
    *,
    angles: int = 5,
    per_angle: int = 3,
    repeats: int = 3,
    campaigns: int = 200,
    turned: int = 3,
    seed: int = 0,
    candidates_per_angle: int = 8,
    starts: int = 2,
    model: str = "exact",
    k1_known: bool = False,
    executor: Executor | None = None,
) -> LoadDirectionFindings:
    """Hanging masses against loads in any direction on ``cell`` (module docstring).

    Parameters
    ----------
    cell
        A cell whose end-effector applies forces in any direction (``[load] directions = "any"``).
    angles, per_angle, repeats
        Size of every plan (q2 angles × configurations per angle) and measurements per configuration.
    campaigns
        Simulated campaigns, the same truths and noise for every plan.
    turned
        Loads of the hanging plan turned sideways in the second plan.
    seed
        Root of the designs' and the campaigns' random draws.
    candidates_per_angle, starts, model
        The designer's candidate set, random starts and search model (:class:`PlanDesigner`);
        the simulations always run the twin and score with the exact linearisation.
    k1_known
        Hold k1 at the cell's value in every truth: what the plans deliver when the config's k1
        happens to be right, so that the hanging plans lose nothing by holding it.
    executor
        Where the campaigns run (default: a process pool on all cores).
    """
    if cell.loading.hanging_only:
        raise ValueError('the study needs a cell whose end-effector applies loads in any direction ([load] directions = "any")')
    hanging_cell = dataclasses.replace(cell, loading=Loading(force_max=cell.loading.force_max))
    options = {"rng": seed, "starts": starts, "candidates_per_angle": candidates_per_angle}
    hanging = PlanDesigner(hanging_cell, repeats=repeats, model=model).optimise(angles, per_angle, "test-pose", **options).plan
    plans = {
        "hanging, test-pose optimal": hanging,
        f"hanging + {turned} sideways": sideways(cell, hanging, turned),
        "free directions, test-pose optimal": PlanDesigner(cell, repeats=repeats, model=model).optimise(angles, per_angle, "test-pose", **options).plan,
    }
    rows, first = {}, None
    for name, plan in plans.items():
        rows[name], length = _plan_scores(cell, plan, first, repeats, campaigns, seed, k1_known, executor)
        first = length if first is None else first
    scores = pd.DataFrame.from_dict(rows, orient="index")
    scores.index.name = "plan"
    settings = {"angles": angles, "per_angle": per_angle, "repeats": repeats, "campaigns": campaigns, "turned": turned, "seed": seed}
    settings |= {"candidates_per_angle": candidates_per_angle, "starts": starts, "model": model, "k1_known": k1_known}
    return LoadDirectionFindings(scores=scores, plans=plans, settings=settings)


def _plan_scores(
    cell: Cell, plan: Plan, first: np.ndarray | None, repeats: int, campaigns: int, seed: int, k1_known: bool, executor: Executor | None
) -> tuple[dict, np.ndarray]:
    """One plan's row of :func:`load_direction_study`'s scores, and its error lengths (m) over the campaigns.

    ``first`` holds the first plan's error lengths on the same campaigns (None: this plan is the first).
    """
    linearised = CampaignModel.build(cell, plan, repeats, vary_all=True)
    if k1_known:
        linearised = dataclasses.replace(linearised, varied=np.arange(len(linearised.varied)) != 0)
    weighted = linearised.design / linearised.sigma[:, np.newaxis]
    prediction = predict(cell, repeats * weighted.T @ weighted, test_design=linearised.test_design)
    result = simulate_plan(cell, plan, campaigns=campaigns, repeats=repeats, seed=seed + 1, executor=executor, model=linearised)
    length = np.linalg.norm(result["errors"], axis=1)
    first = length if first is None else first
    sd_k1 = prediction.relative_sd[0]
    covered = np.abs(result["parameter_errors"][:, 0]) <= 3.0 * sd_k1 if linearised.excited[0] else np.full(campaigns, np.nan)
    return {
        "predicted_rho0_um": prediction.rho0 / UM,
        "predicted_rho0_identified_um": prediction.rho0_identified / UM,
        "mean_error_um": length.mean() / UM,
        "mean_error_se_um": length.std(ddof=1) / math.sqrt(campaigns) / UM,
        "rms_error_um": math.sqrt(np.mean(length**2)) / UM,
        "difference_to_hanging_um": (length - first).mean() / UM,
        "difference_se_um": (length - first).std(ddof=1) / math.sqrt(campaigns) / UM,
        "k1_excited": bool(linearised.excited[0]),
        "k1_identifiable": _k1_reported_identifiable(cell, plan, repeats, seed),
        "k1_width_3sd_pct": 300.0 * sd_k1,
        "k1_width_3sd_urad_per_Nm": 3.0 * sd_k1 * cell.compliances[0] / URAD_PER_NM,
        "k1_coverage_3sd": float(np.mean(covered)),
        "campaigns": campaigns,
    }, length


def _k1_reported_identifiable(cell: Cell, plan: Plan, repeats: int, seed: int) -> bool:
    """Whether the identification's structural analysis reports k1 identifiable on one simulated campaign of ``plan``."""
    campaign = DigitalTwin(cell).simulate(plan, repeats, np.random.default_rng(seed))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, identifiability = ElastostaticModel.from_cell(cell).estimate(campaign)
    return "k1" not in identifiability.not_identifiable
