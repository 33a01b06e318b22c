"""How much accuracy a plan actually leaves at the test pose, over simulated campaigns.

The criteria of :mod:`bayescal.design.criteria` predict the error left at the
test pose from the information matrix of the linearised model.  Here each plan
is measured on the digital twin (the exact loaded equilibrium with the links'
weights, the compensator and the tracker noise) many times, each campaign with
its own true stiffness drawn about the cell's (so that the claim is not
checked only on the truth the plan was optimised for), and identified with the
linear-Gaussian closed form: the weighted least-squares estimate (eq 33, with
the eq-37 weights) of the exact model linearised about the cell's nominal
values by central differences.  This is the estimator eqs 38-39 assume; the
full Bayesian identification (:mod:`bayescal.inference`) agrees with it when
the priors are wide and takes about 40 s per campaign, too long for hundreds
of campaigns per plan.  The compensation then predicts the test point's
deflection with the estimate, and the error left is the distance to the exact
deflection of the campaign's truth.

Parameters the plan cannot excite (``k1`` under hanging loads) are held at
the cell's value in the estimate, as the compensation does
(:mod:`bayescal.compensation.budget`); by default they are held in the truth
too (the error the plan's data leave, ``rho0_identified``), and with
``vary_all`` the truth draws them like the others.  ``from_prior`` names
compliances whose truths every campaign draws from the cell's prior instead
(log-normal about the cell's value with its ``[joints] k_log_sd``), whatever the
plan, so that plans that do and do not excite them meet the same truths and the
error a held value leaves is counted as the criterion ``ρ0`` counts it.

Campaigns run on a :class:`concurrent.futures.Executor`; their seeds are
spawned from one :class:`numpy.random.SeedSequence`, so the result does not
depend on the number of workers, and every plan meets the same truths and the
same noise streams (a paired comparison).
"""

from __future__ import annotations

from collections.abc import Mapping
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.design.criteria import UNEXCITED, nominal_parameters, parameter_names, wrench_information
from bayescal.design.linearisation import ExactLinearisation, test_deflection, with_parameters
from bayescal.design.prediction import predict
from bayescal.design.parallel import seeded_map
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import MM

__all__ = ["CampaignModel", "compare_plans", "simulate_plan"]

TRUTH_SPREAD = {"k": 0.10, "K_c": 0.10, "s0": 0.05}
"""Relative standard deviation of the simulated truths about the cell's values: joint compliances
and K_c within about ±30 % (3σ), s0 within ±15 % so that the spring stays stretched at every q2."""


@dataclass(frozen=True)
class CampaignModel:
    """The exact model of one plan linearised about the cell's values, in relative parameters.

    Attributes
    ----------
    cell, plan, repeats
        What is simulated.
    design : numpy.ndarray
        (configs·markers·3, p) derivatives of the deflections (m), one repeat.
    nominal_deflections : numpy.ndarray
        (configs·markers·3,) deflections at the cell's values, m.
    sigma : numpy.ndarray
        (configs·markers·3,) standard deviation of each deflection coordinate, m.
    excited : numpy.ndarray
        (p,) the parameters the plan excites.
    test_design : numpy.ndarray
        (3, p) derivatives of the test point's exact deflection, m.
    test_nominal : numpy.ndarray
        (3,) the test point's exact deflection at the cell's values, m.
    varied : numpy.ndarray
        (p,) the parameters the simulated truths draw away from the cell's values.
    from_prior : numpy.ndarray
        (p,) the parameters whose truths are drawn from the cell's prior instead.
    """

    cell: Cell
    plan: Plan
    repeats: int
    design: np.ndarray
    nominal_deflections: np.ndarray
    sigma: np.ndarray
    excited: np.ndarray
    test_design: np.ndarray
    test_nominal: np.ndarray
    varied: np.ndarray
    from_prior: np.ndarray

    @classmethod
    def build(cls, cell: Cell, plan: Plan, repeats: int = 3, *, vary_all: bool = False, from_prior: tuple[str, ...] = ()) -> CampaignModel:
        """Linearise the twin's noiseless campaign and the test pose by central differences.

        ``vary_all``: the truths draw every parameter, not only those the plan excites.
        ``from_prior``: joint compliances (``"k1"``) whose truths are drawn from the cell's prior.
        """
        names = parameter_names(cell)
        unknown = [name for name in from_prior if name not in names[: cell.robot.nq]]
        if unknown:
            raise ValueError(f"from_prior takes joint compliances of the cell ({', '.join(names[: cell.robot.nq])}), got {', '.join(unknown)}")
        exact = ExactLinearisation(cell)
        designs, sigmas, deflections = [], [], []
        wrenches = plan.wrenches(cell)
        for q, wrench in zip(plan.q, wrenches):
            design, sigma = exact.wrench_design(q, wrench)
            designs.append(design)
            sigmas.append(sigma)
            deflections.append(exact.wrench_deflections(q, wrench).ravel())
        information = sum(wrench_information(cell, q, w, repeats) for q, w in zip(plan.q, wrenches))
        diagonal = np.diag(information)
        excited = diagonal > UNEXCITED * diagonal.max()
        return cls(
            cell=cell,
            plan=plan,
            repeats=repeats,
            design=np.vstack(designs),
            nominal_deflections=np.concatenate(deflections),
            sigma=np.concatenate(sigmas),
            excited=excited,
            test_design=exact.test_design(),
            test_nominal=test_deflection(cell),
            varied=np.ones_like(excited) if vary_all else excited,
            from_prior=np.array([name in from_prior for name in names]),
        )


def _campaign(index: int, rng: np.random.Generator, model: CampaignModel) -> tuple[np.ndarray, np.ndarray]:
    """One simulated campaign (a task of :func:`~bayescal.design.parallel.seeded_map`): the test point's error
    left (m) and the relative parameter errors."""
    # Truths and noise from two streams of the campaign's own, so that every plan meets the same truths.
    truth_seed, noise_seed = rng.bit_generator.seed_seq.spawn(2)
    cell = model.cell
    names = parameter_names(cell)
    spread = np.array([TRUTH_SPREAD["k"] if name.startswith("k") else TRUTH_SPREAD[name] for name in names])
    z = np.random.default_rng(truth_seed).normal(size=len(names))
    relative_truth = np.where(model.varied, z * spread, 0.0)
    relative_truth[model.from_prior] = np.expm1(cell.compliance_log_sd * z[model.from_prior])
    nominal = nominal_parameters(cell)
    truth_cell = with_parameters(cell, nominal * (1.0 + relative_truth))
    campaign = DigitalTwin(truth_cell).simulate(model.plan, model.repeats, np.random.default_rng(noise_seed))
    # campaign rows: configuration, repeat, marker; the model's: configuration, marker
    n_config = len(model.plan)
    measured = campaign.displacement.reshape(n_config, model.repeats, -1)
    residual = (measured - model.nominal_deflections.reshape(n_config, 1, -1)).reshape(-1)
    design = np.repeat(model.design[:, model.excited].reshape(n_config, 1, -1, np.count_nonzero(model.excited)), model.repeats, axis=1)
    design = design.reshape(len(residual), -1)
    sigma = np.repeat(model.sigma.reshape(n_config, 1, -1), model.repeats, axis=1).reshape(-1)
    estimate = np.zeros(len(names))
    estimate[model.excited] = np.linalg.lstsq(design / sigma[:, np.newaxis], residual / sigma, rcond=None)[0]
    predicted = model.test_nominal + model.test_design @ estimate
    return predicted - test_deflection(truth_cell), estimate - relative_truth


def simulate_plan(
    cell: Cell,
    plan: Plan,
    *,
    campaigns: int = 50,
    repeats: int = 3,
    seed: int = 0,
    executor: Executor | None = None,
    model: CampaignModel | None = None,
) -> dict:
    """Error left at the test pose by ``plan`` over simulated campaigns (module docstring).

    Parameters
    ----------
    cell
        The cell; its values are the centre of the simulated truths.
    plan
        The plan, with its loads (or the cell's).
    campaigns
        Simulated campaigns.
    repeats
        Measurements of each configuration.
    seed
        Root of the campaigns' seeds.
    executor
        Where the campaigns run; default a process pool on all cores.
    model
        The plan's :class:`CampaignModel`, when already built.

    Returns
    -------
    dict
        ``errors`` (campaigns, 3) test-point errors (m), ``parameter_errors``
        (campaigns, p) relative errors of the estimates, ``excited`` (p,) bool.
    """
    if campaigns < 2:
        raise ValueError(f"expected at least 2 campaigns, got {campaigns}")
    model = CampaignModel.build(cell, plan, repeats) if model is None else model
    results = seeded_map(_campaign, range(campaigns), seed, executor=executor, model=model)
    return {
        "errors": np.array([r[0] for r in results]),
        "parameter_errors": np.array([r[1] for r in results]),
        "excited": model.excited,
    }


def _paired_ratio(squared: np.ndarray, first: np.ndarray) -> dict[str, float]:
    """rms of ``squared`` over rms of ``first`` (same campaigns) and its standard error.

    ``log R = (log mean(a) - log mean(b)) / 2``; its variance by the delta method keeps
    the covariance of the paired campaigns, which makes the ratio far more precise than
    the two rms apart.
    """
    a, b = squared, first
    n = len(a)
    ratio = float(np.sqrt(a.mean() / b.mean()))
    if a is b:
        return {"rms_ratio_to_first": 1.0, "rms_ratio_se": 0.0}
    covariance = np.cov(a / a.mean(), b / b.mean())
    variance = 0.25 * (covariance[0, 0] + covariance[1, 1] - 2.0 * covariance[0, 1]) / n
    return {"rms_ratio_to_first": ratio, "rms_ratio_se": ratio * float(np.sqrt(max(variance, 0.0)))}


def _width_rows(plan: str, exact, linear, result: dict) -> list[dict]:
    """:func:`compare_plans`' widths of one plan, a row per parameter: predicted (exact, linear) and simulated, %."""
    simulated = 300.0 * np.sqrt(np.mean(result["parameter_errors"] ** 2, axis=0))
    return [
        {
            "plan": plan,
            "parameter": parameter,
            "predicted_width_3sd_pct": 300.0 * exact.relative_sd[i],
            "predicted_linear_width_3sd_pct": 300.0 * linear.relative_sd[i],
            "simulated_width_3sd_pct": simulated[i] if result["excited"][i] else np.nan,
        }
        for i, parameter in enumerate(exact.names)
    ]


def compare_plans(
    cell: Cell,
    plans: Mapping[str, Plan],
    *,
    campaigns: int = 50,
    repeats: int = 3,
    seed: int = 0,
    executor: Executor | None = None,
    vary_all: bool = False,
    from_prior: tuple[str, ...] = (),
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Plans side by side: predicted ``ρ0`` against the error left over simulated campaigns.

    Every plan meets the same truths and noise streams (the same ``seed``); with
    ``vary_all`` the truths draw the parameters a plan cannot excite too, and the compliances
    named in ``from_prior`` from the cell's prior (module docstring).

    Returns
    -------
    scores : pandas.DataFrame
        Indexed by plan: ``criterion_mm`` (predicted ρ0 of eq 39 with the exact model
        linearised, the priors of unexcited compliances counted), ``criterion_identified_mm``
        (the plan's data alone: what the truths without ``vary_all`` leave), ``criterion_linear_mm`` (with eq 31's design), ``simulated_rms_mm``
        (rms length of the error left at the test pose), ``simulated_rms_se_mm`` (its
        standard error, delta method), ``simulated_q95_mm``, ``rms_ratio_to_first`` (this
        plan's simulated rms over the first plan's, on the same campaigns) and
        ``rms_ratio_se`` (its standard error from the paired campaigns, delta method),
        ``campaigns``.
    widths : pandas.DataFrame
        Indexed by (plan, parameter): ``predicted_width_3sd_pct`` (exact model),
        ``predicted_linear_width_3sd_pct`` and ``simulated_width_3sd_pct``
        (300 × rms relative error of the estimates).
    """
    rows, width_rows, squares = {}, [], []
    for name, plan in plans.items():
        model = CampaignModel.build(cell, plan, repeats, vary_all=vary_all, from_prior=from_prior)
        weighted = model.design / model.sigma[:, np.newaxis]
        exact = predict(cell, repeats * weighted.T @ weighted, test_design=model.test_design)
        linear = predict(cell, sum(wrench_information(cell, q, w, repeats) for q, w in zip(plan.q, plan.wrenches(cell))))
        result = simulate_plan(cell, plan, campaigns=campaigns, repeats=repeats, seed=seed, executor=executor, model=model)
        squared = np.sum(result["errors"] ** 2, axis=1)
        squares.append(squared)
        mean_squared = squared.mean()
        rows[name] = {
            "criterion_mm": exact.rho0 / MM,
            "criterion_identified_mm": exact.rho0_identified / MM,
            "criterion_linear_mm": linear.rho0 / MM,
            "simulated_rms_mm": np.sqrt(mean_squared) / MM,
            "simulated_rms_se_mm": squared.std(ddof=1) / np.sqrt(campaigns) / (2.0 * np.sqrt(mean_squared)) / MM,
            "simulated_q95_mm": np.quantile(np.sqrt(squared), 0.95) / MM,
            **_paired_ratio(squared, squares[0]),
            "campaigns": campaigns,
        }
        width_rows += _width_rows(name, exact, linear, result)
    scores = pd.DataFrame.from_dict(rows, orient="index")
    scores.index.name = "plan"
    return scores, pd.DataFrame(width_rows).set_index(["plan", "parameter"])


def design_comparison(
    cell: Cell,
    *,
    angles: int = 5,
    per_angle: int = 3,
    random_plans: int = 100,
    campaigns: int = 50,
    repeats: int = 3,
    seed: int = 0,
    reference: Plan | None = None,
    executor: Executor | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, Plan]]:
    """The test-pose optimal plan against a reference plan, the best random plans and a D-optimal plan.

    Plans are designed with :class:`~bayescal.design.optimise.PlanDesigner` (exact model)
    from ``seed``; the best of ``random_plans`` random feasible plans is the one with
    the lowest predicted ``ρ0``.  All are then scored by :func:`compare_plans`.

    Returns
    -------
    scores, widths
        As :func:`compare_plans`, with ``violations`` (configurations breaking a
        constraint of the cell) added to ``scores``.
    plans : dict
        The plans, by name.
    """
    from bayescal.design.optimise import PlanDesigner

    designer = PlanDesigner(cell, repeats=repeats)
    rng = np.random.default_rng(seed)
    plans: dict[str, Plan] = {"test-pose optimal": designer.optimise(angles, per_angle, "test-pose", rng=rng).plan}
    if reference is not None:
        plans["reference"] = reference
    candidates = [designer.random_plan(angles, per_angle, rng) for _ in range(random_plans)]
    plans[f"best of {random_plans} random"] = min(candidates, key=lambda plan: designer.evaluate(plan).rho0)
    plans["D-optimal"] = designer.optimise(angles, per_angle, "d-optimal", rng=rng).plan
    scores, widths = compare_plans(cell, plans, campaigns=campaigns, repeats=repeats, seed=seed, executor=executor)
    scores["violations"] = [len(designer.violations(plan)) for plan in plans.values()]
    return scores, widths, plans
