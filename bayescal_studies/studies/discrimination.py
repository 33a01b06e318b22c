"""Whether the plan designed to resolve a tie does: lost motion against torque-dependent compliance.

:func:`tie_resolution` simulates, for each seed, campaigns of one planted effect
with loads of nearly one magnitude until one ties (lost motion and a
torque-dependent compliance within ``DETECTION_Z`` SE of each other on held-out
configurations; at most :data:`TIE_DRAWS` campaigns), designs the plan that
separates ``backlash`` and ``nonlinear_stiffness`` on it
(:class:`~bayescal.design.discriminate.DiscriminatingDesigner`, never told what
was planted), simulates the same truth on that plan, and compares the two
candidates there on held-out configurations
(:meth:`~bayescal.critique.Critique.discriminate`).  The campaigns come from the
digital twin (``twin``) or from the independent generator (``independent``,
:mod:`bayescal.twin.independent`: its own equilibrium, truth drawn unlike the
cell, lost motion with memory, a two-slope joint spring), whose effects were
written apart from the catalogue.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass

import numpy as np
import pandas as pd

from bayescal.design.parallel import seeded_map

__all__ = ["TieCase", "TIE_CASES", "tie_resolution", "BETWEEN"]

BETWEEN = ("backlash", "nonlinear_stiffness")
"""The two candidates a campaign of nearly one load magnitude cannot tell apart."""


@dataclass(frozen=True)
class TieCase:
    """A planted effect, its generator and the candidate that is right.

    Attributes
    ----------
    generator : str
        ``"twin"`` (Table III), ``"independent"`` (its random plans of 6 q2 angles × 5 configurations, 200-300 kg)
        or ``"beams"`` (the third generator, Table III).
    effect : str
        The generator's effect name.
    magnitude : float
        In the effect's unit (twin) or as a multiple of its default (independent).
    right : str
        The candidate of :data:`BETWEEN` that is the planted effect's family.
    """

    generator: str
    effect: str
    magnitude: float
    right: str


TIE_CASES = {
    "twin lost motion": TieCase("twin", "backlash", 0.002, "backlash"),
    "twin torque-dependent": TieCase("twin", "nonlinear_stiffness", 0.15, "nonlinear_stiffness"),
    "independent lost motion": TieCase("independent", "gear_play", 1.0, "backlash"),
    "independent torque-dependent": TieCase("independent", "knee_joints", 0.2, "nonlinear_stiffness"),
    "independent approach lost motion": TieCase("independent", "approach_play", 0.5, "backlash"),
    "third lost motion": TieCase("beams", "lost_motion", 1.0, "backlash"),
    "third hardening": TieCase("beams", "nonlinear_stiffness", 2.0, "nonlinear_stiffness"),
}
"""The cases measured: each effect at a size where, on its campaigns, the two candidates are often
within a few standard errors of each other (a campaign where they are not is drawn again): an eighth
of the twin's default lost motion; half its default stiffening; the independent generator's default
play with memory, two fifths of its default knee, and half its default play taken up on the side each
joint was last driven to (``approach_play``, written apart from the critique's lost motion after that
family was revised on ``gear_play``); the third generator's (:mod:`bayescal.twin.beams`, on Table III, its
38 kg tool weighed in the cell as the rate harness weighs it) play held by friction at its default, and its
hardening gears at twice their default, where they tie with lost motion on Table III in 34 of 40
campaigns (docs/critique.md).  No rule of the design was set on the third generator."""


TIE_DRAWS = 12
"""Campaigns drawn at most, per seed, for one on which the two candidates tie (each a new truth, plan and noise)."""


def _campaigns(case: TieCase, cell, table3, seed: np.random.SeedSequence):
    """``simulate(plan, rng_child)``: campaigns of one truth on any plan, and the tied campaign's plan."""
    from bayescal.twin.effects import parse_effect
    from bayescal.twin.independent import IndependentGenerator, random_plan
    from bayescal.twin.simulator import DigitalTwin

    plan_seed, truth_seed, noise_seed = (int(s.generate_state(1)[0]) for s in seed.spawn(3))
    if case.generator == "twin":
        twin = DigitalTwin(cell, [parse_effect(f"{case.effect}={case.magnitude!r}")])
        return (lambda plan, k: twin.simulate(plan, 3, np.random.default_rng([noise_seed, k]))), table3
    if case.generator == "beams":
        return _beams_campaigns(case, cell, noise_seed), table3

    world = IndependentGenerator(cell, np.random.default_rng(truth_seed)).world(case.effect, case.magnitude)

    def simulate(plan, k):
        generator = IndependentGenerator(cell, np.random.default_rng([noise_seed, k]))
        return generator.simulate(plan, 3, case.effect, case.magnitude, world=world)[0]

    return simulate, random_plan(cell, np.random.default_rng(plan_seed))


def _beams_campaigns(case: TieCase, cell, noise_seed: int):
    """``simulate(plan, k)`` of the third generator: its campaign of ``plan`` written to a file and read back as
    ``bayescal critique`` reads it (its arm and effect fixed, the noise and the play's first state by the seed)."""
    import tempfile
    from pathlib import Path

    from bayescal.cell.campaign import read_campaign
    from bayescal.twin.beams import generate_campaign

    def simulate(plan, k):
        frame = pd.DataFrame(np.degrees(plan.q), columns=[f"q{j + 1}_deg" for j in range(plan.q.shape[1])])
        frame["load_kg"] = plan.masses(cell.load_mass)
        with tempfile.TemporaryDirectory() as folder:
            seed = int(np.random.SeedSequence([noise_seed, k]).generate_state(1)[0])
            path = generate_campaign(frame, effect=case.effect, magnitude=case.magnitude, seed=seed).write(Path(folder) / "campaign.csv")[0]
            return read_campaign(path, cell=cell)

    return simulate


def _read_with(case: TieCase, cell):
    """The cell the campaigns of ``case`` are read and designed with: the third generator's tool weighed in it."""
    from bayescal_studies.studies.critique_rates import GENERATORS, weighed_cell

    return weighed_cell(cell, GENERATORS["beams"], case.effect) if case.generator == "beams" else cell


def _one(
    case: TieCase, rng: np.random.Generator, *, cell, plan, mass_range: tuple[float, float], angles: int, per_angle: int,
    candidates_per_angle: int, starts: int, criticise: bool = False,
) -> dict:
    """One seed (a task of :func:`~bayescal.design.parallel.seeded_map`): the tied campaign, the designed plan,
    and the comparison on the plan's campaign."""
    from bayescal.critique import Critique
    from bayescal.critique.rule import DETECTION_Z
    from bayescal.design.constraints import load_design_space
    from bayescal.design.discriminate import DiscriminatingDesigner

    # The task's stream: its children seed each draw's plan, truth and noise, and the design.
    seed = rng.bit_generator.seed_seq
    cell = _read_with(case, cell)
    draws, design_seed = seed.spawn(TIE_DRAWS), seed.spawn(1)[0]
    wrong = BETWEEN[1] if case.right == BETWEEN[0] else BETWEEN[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        # the experiment is for a campaign that cannot tell the two apart: draw until one does not
        for drawn, draw in enumerate(draws, start=1):
            simulate, tied_plan = _campaigns(case, cell, plan, draw)
            tied = simulate(tied_plan, 0)
            before = Critique(cell).discriminate(tied, wrong, case.right)
            if abs(before.delta_elpd) <= DETECTION_Z * before.se:
                break
        else:
            return {"draws": TIE_DRAWS, "tied_delta_elpd": before.delta_elpd, "tied_se": before.se, "tied": False}
        space = load_design_space(cell, mass_range=mass_range)
        design = DiscriminatingDesigner(cell, BETWEEN, tied, space).optimise(
            angles, per_angle, np.random.default_rng(design_seed), starts=starts, candidates_per_angle=candidates_per_angle
        )
        planned = simulate(design.plan, 1)
        after = Critique(cell).discriminate(planned, wrong, case.right)
        judged = _criticised(cell, planned, case.right, seed.spawn(1)[0]) if criticise else {}
    return judged | {
        "draws": drawn,
        "tied_delta_elpd": before.delta_elpd,
        "tied_se": before.se,
        "tied": True,
        "planned_worst_nats": design.planned.worst,
        "planned_worst_z": min(design.planned.z),
        "delta_elpd": after.delta_elpd,
        "se": after.se,
        "separated": after.delta_elpd > DETECTION_Z * after.se,
    }


def _criticised(cell, campaign, right: str, seed: np.random.SeedSequence) -> dict:
    """The whole critique of the plan's ``campaign``, its first cause judged against ``right`` as the rate harness judges it."""
    from bayescal.critique import Critique
    from bayescal_studies.studies.critique_rates import judged

    result = Critique(cell).run(campaign, np.random.default_rng(seed))
    return {"causes": ",".join(result.causes)} | judged(list(result.causes), result.tied_with, result.contested_by, right)


def _case_seeds(cases: Sequence[str], n_seeds: int, seed: int) -> tuple[list, list[np.random.SeedSequence]]:
    """The :data:`TIE_CASES` entry and the seed of each of ``n_seeds`` campaigns of every case, case by case."""
    unknown = [name for name in cases if name not in TIE_CASES]
    if unknown:
        raise ValueError(f"unknown tie cases {unknown}; expected names of TIE_CASES: {', '.join(TIE_CASES)}")
    # each case's seeds hang off its place in TIE_CASES, so that a case gets the same campaigns alone or with others
    roots = dict(zip(TIE_CASES, np.random.SeedSequence(seed).spawn(len(TIE_CASES))))
    streams = [s for name in cases for s in roots[name].spawn(n_seeds)]
    return [TIE_CASES[name] for name in cases for _ in range(n_seeds)], streams


def tie_resolution(
    config: str,
    table3: str,
    cases: Sequence[str] = tuple(TIE_CASES),
    *,
    n_seeds: int = 20,
    seed: int = 0,
    mass_range: tuple[float, float] = (50.0, 280.0),
    angles: int = 5,
    per_angle: int | None = None,
    candidates_per_angle: int = 4,
    starts: int = 1,
    criticise: bool = False,
    executor: Executor | None = None,
) -> pd.DataFrame:
    """Per case and seed: the tie on the campaign, and the right candidate's lead on the discriminating plan's campaign.

    Parameters
    ----------
    config, table3
        The cell TOML and Table III's plan CSV (the twin's tied campaigns).
    cases, n_seeds
        Names of :data:`TIE_CASES`, and seeds per case.
    seed
        Root of the :class:`numpy.random.SeedSequence` of every campaign and plan (a case's the same with any others).
    mass_range
        The masses (kg) the discriminating plan may hang.
    angles, per_angle
        The plan's q2 angles and configurations per angle, each measured 3 times (default the command's).
    candidates_per_angle, starts
        Candidate configurations per q2 angle of the plan's search, and its random starts (the command's: 8 and 4).
    criticise
        Also criticise the plan's campaign whole and judge its first cause as the rate harness does (``causes, first,
        partners, alone, right, wrong_single``).
    executor
        Runs the seeds (:func:`~bayescal.design.parallel.seeded_map`; default a process pool).

    Returns
    -------
    pandas.DataFrame
        One row per case and seed: ``case, seed, draws, tied_delta_elpd, tied_se, tied, planned_worst_nats,
        planned_worst_z, delta_elpd, se, separated`` (``draws`` the campaigns drawn for a tie, ``tied``
        whether one came; ΔELPD of the right candidate over the wrong one, nats; ``planned_worst_z`` the
        plan's expected ΔELPD in SEs, the worse of the two truths; ``separated`` when it exceeds 2 SE;
        the plan's columns are NaN where no campaign tied).
    """
    from bayescal.cell.config import load_cell
    from bayescal.cell.plan import read_plan
    from bayescal.design.discriminate import PER_ANGLE

    items, streams = _case_seeds(cases, n_seeds, seed)
    cell = load_cell(config)
    results = seeded_map(
        _one, items, streams, executor=executor,
        cell=cell, plan=read_plan(table3, cell.robot), mass_range=tuple(mass_range), angles=angles,
        per_angle=PER_ANGLE if per_angle is None else per_angle, candidates_per_angle=candidates_per_angle, starts=starts, criticise=criticise,
    )
    labels = ({"case": name, "seed": k} for name in cases for k in range(n_seeds))
    return pd.DataFrame.from_records([label | record for label, record in zip(labels, results)])
