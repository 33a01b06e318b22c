"""Coverage of the elastostatic intervals on simulated campaigns unlike the config.

Each campaign draws its own truth around, not at, the cell's values (joint
compliances, the compensator's K_c and s0, the link masses), its own random
feasible plan (q2 angles spread over the joint range, several configurations
at each) and its own tracker noise, simulates the campaign on the digital
twin with that truth, and identifies it with the model built from the
unchanged cell: what a user does, who never knows the truth.  The table says
for every parameter of every campaign how far the truth lies from the
posterior mean in posterior sd, and whether the parameter was reported
identifiable, so that coverage is counted separately for both.
"""

from __future__ import annotations

import dataclasses
import warnings
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan, prismatic_flags
from bayescal.design.loads import draw_loads
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.exact import scale_masses
from bayescal.inference.parameters import ParameterRegistry
from bayescal.inference.results import ElastostaticResults
from bayescal.sampling.protocol import Sampler
from bayescal.design.parallel import seeded_map
from bayescal.twin.simulator import DigitalTwin

__all__ = ["Truth", "TruthSpread", "elastostatic_coverage", "fit_against_truth", "independent_coverage", "random_plan"]

LIMIT_MARGIN = 0.1
"""Fraction of each joint's range kept clear of its limits when drawing configurations."""


@dataclasses.dataclass(frozen=True)
class TruthSpread:
    """How far a simulated truth is drawn from the cell's values: uniform factors ``1 ± spread``.

    The defaults put the compensator's spring and the link masses well away
    from the config (the URDF's masses are estimates; K_c and s0 are what a
    calibration is for) and the joint compliances within ±10 %.
    """

    compliances: float = 0.1
    K_c: float = 0.3
    s0: float = 0.05
    masses: float = 0.15

    def draw(self, cell: Cell, rng: np.random.Generator) -> Truth:
        """A truth drawn about ``cell``'s values: each joint compliance, K_c, s0 and the link masses
        times its own uniform factor (in that order of draws)."""
        factor = lambda width, n=None: rng.uniform(1.0 - width, 1.0 + width, n)  # noqa: E731
        compliances = cell.compliances * factor(self.compliances, cell.robot.nq)
        # A robot without a compensator has no spring to draw.
        spring = None if cell.compensator is None else (cell.compensator.K_c * factor(self.K_c), cell.compensator.s0 * factor(self.s0))
        return Truth(compliances=compliances, spring=spring, masses=factor(self.masses))


def random_plan(cell: Cell, angles: int, per_angle: int, rng: np.random.Generator) -> Plan:
    """A plan of ``angles`` q2 angles spread over joint 2's range with ``per_angle`` random configurations each.

    The other joints are uniform within their limits, :data:`LIMIT_MARGIN` clear of them.  On a cell
    whose end-effector applies loads in any direction, each configuration gets a force of ``F_max``
    (and a couple of ``couple_max_Nm``) in a direction uniform on the sphere; otherwise the cell's mass.
    """
    robot = cell.robot
    low = robot.lower + LIMIT_MARGIN * (robot.upper - robot.lower)
    high = robot.upper - LIMIT_MARGIN * (robot.upper - robot.lower)
    edges = np.linspace(low[cell.plan_joint], high[cell.plan_joint], angles + 1)
    q2 = rng.uniform(edges[:-1], edges[1:])
    q = rng.uniform(low, high, (angles * per_angle, robot.nq))
    q[:, cell.plan_joint] = np.repeat(q2, per_angle)
    plan = Plan(q=q, load_kg=None, lines=np.zeros(len(q), dtype=int), source="random plan", prismatic=prismatic_flags(robot))
    if cell.loading.hanging_only:
        return plan
    loads = draw_loads(len(q) + 1, cell.loading.force_max, cell.loading.couple_max, rng)[1:]  # the first is straight down
    return dataclasses.replace(plan, force=loads[:, :3], couple=loads[:, 3:] if cell.loading.couple_max > 0 else None)


def elastostatic_coverage(
    cell: Cell,
    campaigns: int,
    seed: int,
    *,
    sampler: Sampler | None = None,
    spread: TruthSpread = TruthSpread(),
    angles: int = 6,
    per_angle: int = 5,
    repeats: int = 3,
    noise_um: float | None = 8.0,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """Truth against posterior for ``campaigns`` simulated calibrations.

    Parameters
    ----------
    cell
        The cell the identification assumes.
    campaigns
        Number of simulated campaigns.
    seed
        Root of every random draw (truths, plans, noise, samplers).
    sampler
        The identification's sampler (default: the model's).
    spread
        How far each truth is drawn from the cell's values.
    angles, per_angle, repeats
        Plan size: q2 angles, configurations per angle, repeats per configuration.
    noise_um
        Tracker noise sd per coordinate (μm), the same at every distance; None:
        the cell's distance-dependent tracker model.
    executor
        Where the campaigns run (:func:`~bayescal.design.parallel.seeded_map`).

    Returns
    -------
    pandas.DataFrame
        One row per campaign and parameter (``k2``..``k6``, ``K_c``, ``s0``,
        ``gravity_scale``): ``campaign``, ``parameter``, ``truth``, ``mean``,
        ``sd`` (edge units), ``z`` = (truth - mean) / sd, ``identifiable``, and the
        fit's worst ``r_hat`` (NaN when a chain never moved).
    """
    rows = seeded_map(
        _one_campaign,
        range(campaigns),
        seed,
        executor=executor,
        cell=cell,
        sampler=sampler,
        spread=spread,
        size=(angles, per_angle, repeats),
        noise_um=noise_um,
    )
    return pd.DataFrame([row for campaign in rows for row in campaign])


def _one_campaign(index: int, rng: np.random.Generator, *, cell, sampler, spread, size, noise_um) -> list[dict]:
    truth = spread.draw(cell, rng)
    return [{"campaign": index} | row for row in fit_against_truth(cell, truth, rng, sampler=sampler, size=size, noise_um=noise_um)]


@dataclasses.dataclass(frozen=True)
class Truth:
    """What the twin simulates where the cell only guesses: joint compliances (rad/(N·m)), the compensator law's
    values (SI; the spring's ``(K_c (N/m), s0 (m))``; None without a compensator) and a factor on every link's mass."""

    compliances: np.ndarray
    spring: tuple[float, float] | None
    masses: float = 1.0


def fit_against_truth(
    cell: Cell,
    truth: Truth,
    rng: np.random.Generator,
    *,
    sampler: Sampler | None = None,
    size: tuple[int, int, int] = (6, 5, 3),
    noise_um: float | None = 8.0,
    extensions: int = 0,
) -> list[dict]:
    """Simulate a random campaign with ``truth``, identify it with the model of the unchanged ``cell``.

    Parameters
    ----------
    cell
        The cell as the user knows it: the model is built from it.
    truth
        What the twin simulates instead of the cell's values.
    rng
        Source of the plan, the noise and the sampler's randomness.
    sampler
        The posterior sampler (default: the model's).
    size
        ``(angles, per_angle, repeats)`` of the random plan (:func:`random_plan`).
    noise_um
        Tracker noise sd per coordinate (μm) at every distance; None: the cell's tracker model.
    extensions
        Runs the sampling may be extended by while it falls short of convergence
        (:class:`~bayescal.inference.elastostatic.ElastostaticModel`'s ``extensions``; ``bayescal calibrate``'s
        :data:`~bayescal.inference.elastostatic.EXTENSIONS`).

    Returns
    -------
    list of dict
        Per parameter (``k2``..``k6``, with ``k1`` on a cell whose loads go in any direction,
        ``K_c``, ``s0``, ``gravity_scale``) in edge units:
        ``parameter``, ``truth``, ``mean``, ``sd``, ``z`` = (truth - mean) / sd,
        ``identifiable``, and the fit's worst ``r_hat``.
    """
    tracker = cell.tracker
    if noise_um is not None:
        # A tracker whose error does not grow with distance: U1 = 0, U0 scaled to the sd wanted.
        tracker = dataclasses.replace(tracker, U0=noise_um * 1e-6 / tracker.factor, U1=0.0)
    twin = dataclasses.replace(
        cell,
        robot=scale_masses(cell.robot, truth.masses),
        compliances=truth.compliances,
        compensator=None if truth.spring is None else cell.compensator.at(cell.compensator.vector, truth.spring),
        tracker=tracker,
    )
    plan = random_plan(cell, *size[:2], rng)
    campaign = DigitalTwin(twin).simulate(plan, size[2], rng)
    options = {} if sampler is None else {"sampler": sampler}
    model = ElastostaticModel.from_cell(dataclasses.replace(cell, tracker=tracker), extensions=extensions, **options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = model.fit(campaign, rng)
    return _against_truth(cell, truth, results)


def _against_truth(cell: Cell, truth: Truth, results: ElastostaticResults) -> list[dict]:
    """:func:`fit_against_truth`'s rows: each sampled parameter's truth beside its posterior, edge units."""
    summary = results.summary()
    not_identifiable = results.identifiability.not_identifiable
    r_hat = results.diagnostics()["r_hat_max"]
    values = ParameterRegistry.of_cell(cell).edge_values(truth.compliances, truth.spring)
    if cell.loading.hanging_only:
        # hanging masses never turn A1 (k1 stays the config's); loads in any direction do
        del values["k1"]
    values["gravity_scale"] = truth.masses
    out = []
    for name, value in values.items():
        if name not in summary.index:
            continue
        mean, sd = summary.loc[name, "mean"], summary.loc[name, "sd"]
        out.append(
            {
                "parameter": name,
                "truth": value,
                "mean": mean,
                "sd": sd,
                "z": (value - mean) / sd,
                "identifiable": name not in not_identifiable,
                "r_hat": r_hat,
            }
        )
    return out


def independent_coverage(
    cell: Cell,
    campaigns: int,
    seed: int,
    *,
    angles: int = 6,
    per_angle: int = 5,
    repeats: int = 3,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """Truth against posterior for campaigns of :mod:`bayescal.twin.independent`, written apart from the model.

    Each campaign draws its truth (compliances, spring, link masses), its tool and its
    anisotropic tracker noise from the independent generator, on its own random plan of
    masses over the cell's ``[design] mass_kg`` range (its calibration mass when it gives
    none), and is identified with the model of the unchanged cell.

    Returns
    -------
    pandas.DataFrame
        One row per campaign and joint compliance the fit reports identifiable: ``campaign``,
        ``parameter``, ``truth``, ``mean``, ``sd`` (edge units) and ``z`` = (truth - mean) / sd.
    """
    rows = seeded_map(_independent_campaign, range(campaigns), seed, executor=executor, cell=cell, size=(angles, per_angle, repeats))
    return pd.DataFrame([row for campaign in rows for row in campaign])


def _independent_campaign(index: int, rng: np.random.Generator, *, cell: Cell, size: tuple[int, int, int]) -> list[dict]:
    from bayescal.twin.independent.generator import IndependentGenerator
    from bayescal.twin.independent.plans import random_plan as independent_plan

    masses = cell.design.mass_range or (cell.load_mass, cell.load_mass)
    plan = independent_plan(cell, rng, angles=size[0], per_angle=size[1], mass_kg=masses)
    campaign, truth = IndependentGenerator(cell, rng).simulate(plan, size[2])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell).fit(campaign, rng)
    summary, reasons, registry = results.summary(), results.identifiability.not_identifiable, ParameterRegistry.of_cell(cell)
    out = []
    for j, value in enumerate(truth.world.compliances):
        name = f"k{j + 1}"
        if name in summary.index and name not in reasons:
            true, mean, sd = registry[name].to_edge(value), summary.loc[name, "mean"], summary.loc[name, "sd"]
            out.append({"campaign": index, "parameter": name, "truth": true, "mean": mean, "sd": sd, "z": (true - mean) / sd})
    return out
