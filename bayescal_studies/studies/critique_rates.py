"""The critique's rates on the three campaign generators, by one harness.

A *generator* here is whatever writes, for an effect, a multiple of that effect's default magnitude, a seed
and whether reference nests are read, the files ``bayescal critique`` reads: a campaign CSV and, with
nests, a nests CSV (:class:`RateGenerator`).  :func:`critique_rates` has each generator write its files,
reads them back and runs the critique exactly as the command does (``read_campaign(path, cell=cell)``,
``read_nests``, ``Critique(cell).run(campaign, rng, nests=nests)``), one row per campaign; :func:`rates`
tabulates per case the planted cause named first and alone, right counting ties, a wrong single cause and
adequate, with binomial standard errors, and :func:`confusion` what was named first instead.

What counts as right is one table per generator (:data:`GENERATORS`, ``expected``): the critique's candidate
the generator's effect belongs to, ``adequate`` where nothing is planted, ``unexplained`` for an effect of no
candidate's family.  One choice applies to every generator: with reference nests a planted drift of the
tracker is measured from the nests and removed before any fit (``drift`` is then no candidate), so the right
verdict is ``adequate``.
"""

from __future__ import annotations

import tempfile
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["RateGenerator", "GENERATORS", "SET_ON", "check_case", "critique_rates", "rates", "confusion", "markdown_rates", "judged", "weighed_cell"]

ADEQUATE = "adequate"


@dataclass(frozen=True)
class RateGenerator:
    """A campaign generator as the harness sees it.

    Attributes
    ----------
    name : str
    expected : dict
        The generator's effect name to the critique's verdict that is right for it: a candidate of
        :data:`~bayescal.critique.extensions.CATALOGUE`, ``"unexplained"``, or ``"adequate"`` (``"none"``).
    write : callable
        ``write(effect, multiple, seed, nests, folder, cell, plan) -> (campaign_path, nests_path or None)``:
        the campaign of ``effect`` at ``multiple`` times its default, seeded ``seed``, written into ``folder``.
    tool : callable
        ``tool(effect, cell) -> (mass kg, centre (3,) m in the flange frame) or None``: the tool's weight the
        generator simulates with ``effect``, which a user weighs and writes into the cell's ``[tool] mass_kg`` and
        ``com_mm``; the critique reads the campaign with the cell carrying it (None: the cell as it is).
    """

    name: str
    expected: dict[str, str]
    write: Callable[..., tuple[Path, Path | None]]
    tool: Callable[..., tuple[float, np.ndarray] | None] = lambda effect, cell: None


def _write_beams(effect, multiple, seed, nests, folder, cell, plan, robot=None):
    """The third generator's campaign of ``plan`` (3 repeats, a configuration's repeats in a row) on ``robot`` (its own arm)."""
    from bayescal.twin.beams import generate_campaign

    campaign = generate_campaign(plan, effect=effect, magnitude=multiple, seed=seed, nests=nests, robot=robot)
    paths = campaign.write(Path(folder) / "campaign.csv")
    return paths[0], paths[1] if nests else None


RIGID_LINKS = 1e-6
"""The compliance factor that makes the third generator's beams rigid: their 120 μm rms of Table III's deflections
become 0.1 nm, far below the tracker's noise."""


def _write_beams_rigid(effect, multiple, seed, nests, folder, cell, plan):
    """The third generator's campaign on its arm with the upper arm's and forearm's beams made rigid: the arm the
    classical model describes (joint compliances, a compensator, a rigid tool but for its mount's hinge, which the
    joint-6 compliance takes), so that nothing planted is the null the false-alarm rate is measured on."""
    from bayescal.twin.beams.kr270 import kr270_class

    arm = kr270_class()
    beams = tuple(item.name for item in arm.items if item.kind == "elastic" and item.name != "tool mount hinge")
    return _write_beams(effect, multiple, seed, nests, folder, cell, plan, robot=arm.with_elastic(beams, RIGID_LINKS))


def _beams_tool(effect, cell):
    """The third generator's tool, 38 kg, whatever the effect (:data:`bayescal.twin.beams.kr270.MASSES`)."""
    from bayescal.twin.beams.kr270 import MASSES

    mass, centre = MASSES["tool"]
    return mass, np.asarray(centre, dtype=float)


def _write_independent(effect, multiple, seed, nests, folder, cell, plan):
    """The second generator's campaign: a random plan of its own (``plan`` unused), 3 repeats, as
    :func:`~bayescal_studies.studies.independent_detection.independent_detection` draws it for the same seed."""
    from bayescal.twin.independent import IndependentGenerator, random_plan

    rng = np.random.default_rng(seed)
    planted = None if effect == "none" else effect
    campaign, truth = IndependentGenerator(cell, rng).simulate(random_plan(cell, rng), 3, planted, multiple, nests=nests)
    return _written(campaign, truth.nests, folder)


def _independent_tool(effect, cell):
    """The independent generator's tool: weighed only where it plants one (``tool_mount``, 30 kg), its centre of mass
    where the generator puts it, midway between the flange and the centroid of the cell's load point and markers."""
    from bayescal.twin.independent.effects import TOOL_MASS

    if effect != "tool_mount":
        return None
    carried = np.vstack([cell.load_point, *cell.markers.values()])
    return TOOL_MASS, 0.5 * carried.mean(axis=0)


TWIN_DEFAULTS = {"compensator": 30.0}
"""The twin's magnitudes at multiple 1 where its effect's own default plants nothing: ``compensator`` scales
K_c, whose default 1 is the cell's spring; 30 × K_c is the smallest magnitude ``reports/detection.md`` finds
first in 90 % of Table III campaigns.  Every other effect at multiple 1 is its documented default."""


def _write_twin(effect, multiple, seed, nests, folder, cell, plan):
    """The digital twin's campaign of ``plan`` (3 repeats); ``drift`` is the tracker's drift at its default rate."""
    from bayescal.cell.plan import read_plan
    from bayescal.twin.drift import TrackerDrift
    from bayescal.twin.effects import EFFECTS
    from bayescal.twin.simulator import DigitalTwin

    rng = np.random.default_rng(seed)
    effects = [] if effect in ("none", "drift") else [EFFECTS[effect](TWIN_DEFAULTS.get(effect, EFFECTS[effect].default) * multiple)]
    drift = TrackerDrift(TrackerDrift.default * multiple) if effect == "drift" else None
    twin, robot_plan = DigitalTwin(cell, effects, drift=drift), read_plan(plan, cell.robot)
    if nests:
        return _written(*twin.simulate_with_nests(robot_plan, 3, rng), folder)
    return _written(twin.simulate(robot_plan, 3, rng), None, folder)


def _written(campaign, nests, folder) -> tuple[Path, Path | None]:
    """Write an in-memory campaign (and its nests) as the files the command reads."""
    from bayescal.cell.campaign import write_campaign

    path = Path(folder) / "campaign.csv"
    write_campaign(campaign, path)
    if nests is None:
        return path, None
    nests.write(Path(folder) / "campaign_nests.csv")
    return path, Path(folder) / "campaign_nests.csv"


GENERATORS: dict[str, RateGenerator] = {
    "beams": RateGenerator("beams", {
        "none": ADEQUATE, "compensator": "compensator", "link_compliance": "link_compliance", "tool_compliance": "tool_compliance",
        "lost_motion": "backlash", "nonlinear_stiffness": "nonlinear_stiffness", "outliers": "outliers", "drift": "drift",
    }, _write_beams, _beams_tool),
    "beams_rigid": RateGenerator("beams_rigid", {
        "none": ADEQUATE, "compensator": "compensator", "tool_compliance": "tool_compliance", "lost_motion": "backlash",
        "nonlinear_stiffness": "nonlinear_stiffness", "outliers": "outliers", "drift": "drift",
    }, _write_beams_rigid, _beams_tool),
    "independent": RateGenerator("independent", {
        "none": ADEQUATE, "link_beams": "link_compliance", "tool_mount": "tool_compliance", "gear_play": "backlash",
        "approach_play": "backlash", "knee_joints": "nonlinear_stiffness", "los_jumps": "outliers", "thermal_drift": "drift",
        "random_field": "unexplained",
    }, _write_independent, _independent_tool),
    "twin": RateGenerator("twin", {
        "none": ADEQUATE, "compensator": "compensator", "link_compliance": "link_compliance", "tool_compliance": "tool_compliance",
        "backlash": "backlash", "nonlinear_stiffness": "nonlinear_stiffness", "outliers": "outliers", "drift": "drift",
    }, _write_twin),
}
"""The three generators and, per effect, the verdict that is right.

* ``beams`` (:mod:`bayescal.twin.beams`, Table III): its Timoshenko beams made softer are ``link_compliance``
  (a beam's tip compliance is the family's 6-D spring, shear added); its tool mount's hinge, an axis 13° off the
  flange axis, is ``tool_compliance`` to first order (the family is transversely isotropic about the flange axis);
  its gas spring is ``compensator`` although it changes the deflections by 2.6 μm rms (``docs/generators.md``);
  its play held by friction is ``backlash``.  Its arm's own beams are 120 μm rms of Table III's deflections, a
  compliance the classical model does not have, so its ``none`` is not the classical model's null.
* ``beams_rigid``: the same generator on its arm with the beams made rigid (:data:`RIGID_LINKS`): its ``none`` is
  the null of the false-alarm rate; ``link_compliance`` has nothing to soften and is left out.
* ``independent`` (:mod:`bayescal.twin.independent`, random plans of 30 configurations): the families of its
  effects (:data:`bayescal.twin.independent.effects.EFFECTS`); ``random_field`` has none and is right as
  ``unexplained``.  Left out as in :data:`~bayescal_studies.studies.independent_detection.INDEPENDENT_EFFECTS`:
  ``stiff_spring``, ``load_rehang``, ``tracker_scale``.
* ``twin`` (:mod:`bayescal.twin.effects`, Table III): each effect is its candidate's namesake; ``drift`` is
  :class:`~bayescal.twin.drift.TrackerDrift`.

The critique reads each campaign with the cell carrying the tool's weight the generator simulates (``tool``), as a
user who weighed the tool would: the third generator's 38 kg in every campaign, the independent generator's 30 kg
with ``tool_mount``; the twin simulates the cell's own tool."""

SET_ON: dict[str, str] = {
    "twin": "all: the naming rule's constants (DETECTION_Z, DETECTION_FLOOR, DECISIVE_GAIN; SEPARABLE_CHI2 follows from the first two), the catalogue "
            "and its settings, the drift evidence, the repeats' clause (no constant of its own; written after its "
            "link_compliance, seeds 0-39), the walk in the drift candidate's column beside the steady rate (its "
            "drift at twice the default, seeds 0-39), and a tie as the whole plan's (its compensator's ties, seeds 0-39)",
    "independent": "the lost-motion family's settings (friction holds, side on arrival, compensated-joint torque "
                   "shifts; after gear_play and approach_play; the holds as fractions of the rated torque, chosen on "
                   "the breakaway torques the twin and this generator take), the drift evidence's first-reading "
                   "rule (gear_play, seeds 9000-9002), the encompassing of a contest (no constant; judged on "
                   "gear_play and approach_play, seeds 9000-9039), the gross errors' tail per reading against "
                   "the arm's per state (no constant; diagnosed on gear_play, seeds 9001-9011, and los_jumps, seeds "
                   "9000-9004; judged on gear_play and approach_play, seeds 9000-9039), the drift's guard on the repeats' clause "
                   "(no constant of its own; thermal_drift, seeds 9000-9039, and at three times its default 9000-9019), "
                   "and the steady rate in the drift candidate's column (thermal_drift, seeds 9000-9005)",
    "beams": "the choice of the held-out density over the naming rule for the unit of a heavy tail (per reading or per "
             "state), made after its lost_motion at twice the default (seeds 0-39), and a candidate's variants integrated "
             "out of its held-out score (no constant; diagnosed on its link_compliance, seeds 0-39, and the mixture "
             "preferred to the variant chosen without each configuration after its lost_motion and link_compliance); a tie as "
             "the whole plan's (no constant; its hardening's ties at twice the default listed with their chi2 beside the "
             "twin's compensator)",
    "beams_rigid": "none",
}
"""Which of the critique's rules were set on campaigns of each generator (docs/critique.md); the rates of the others
are out of sample."""


def _expected(generator: RateGenerator, effect: str, nests: bool) -> str:
    """The right verdict: with nests a planted drift is removed before the critique, so ``adequate``."""
    expected = generator.expected[effect]
    return ADEQUATE if nests and expected == "drift" else expected


def judged(causes: list[str], tied: dict, contested: dict, expected: str) -> dict:
    """Whether the first cause is the expected one alone, right counting ties and contests, or a wrong single cause."""
    first = causes[0] if causes else None
    partners = list(tied.get(first, [])) + list(contested.get(first, [])) if first else []
    if expected == ADEQUATE:
        right = alone = not causes
    elif expected == "unexplained":
        right, alone = "unexplained" in causes, causes == ["unexplained"]
    else:
        right, alone = first == expected or expected in partners, first == expected and not partners
    return {"first": first or ADEQUATE, "partners": "+".join(sorted(partners)), "alone": alone, "right": right,
            "wrong_single": bool(causes) and not right and not partners}


def weighed_cell(cell, generator: RateGenerator, effect: str):
    """The cell the critique reads ``effect``'s campaigns with: ``cell`` carrying the generator's tool weight."""
    from dataclasses import replace

    tool = generator.tool(effect, cell)
    if tool is None:
        return cell
    if cell.robot.tool_mass > 0:
        raise ValueError(f"{cell.source} weighs a tool already; the {generator.name} generator simulates its own")
    return replace(cell, robot=cell.robot.with_tool(*tool))


def _one(case: tuple, rng: np.random.Generator, cell, plan: str) -> dict:
    """One campaign written by its generator and criticised as ``bayescal critique`` does, with the cell carrying the
    generator's tool weight (a task of :func:`~bayescal.design.parallel.seeded_map`)."""
    from bayescal.cell.campaign import read_campaign
    from bayescal.cell.nests import read_nests, require_times
    from bayescal.critique import Critique

    name, effect, multiple, nests, seed = case
    generator = GENERATORS[name]
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        # the plan's warnings (e.g. all loads parallel) are the same for every campaign of a case
        warnings.simplefilter("ignore", UserWarning)
        campaign_path, nests_path = generator.write(effect, multiple, seed, nests, folder, cell, plan)
        weighed = weighed_cell(cell, generator, effect)
        campaign = read_campaign(campaign_path, cell=weighed)
        readings = None
        if nests_path is not None:
            readings = read_nests(nests_path)
            require_times(campaign.times, campaign.source)
        result = Critique(weighed).run(campaign, rng, nests=readings)
    causes = list(result.causes)
    expected = _expected(generator, effect, nests)
    return {"generator": name, "effect": effect, "multiple": multiple, "nests": nests, "seed": seed, "expected": expected,
            "causes": ",".join(causes)} | judged(causes, result.tied_with, result.contested_by, expected)


def check_case(generator: str, effects: Sequence[str]) -> None:
    """Refuse a generator not in :data:`GENERATORS`, or effects it does not plant."""
    if generator not in GENERATORS:
        raise ValueError(f"unknown generator {generator!r}; expected one of {', '.join(GENERATORS)}")
    unknown = [e for e in effects if e not in GENERATORS[generator].expected]
    if unknown:
        raise ValueError(f"unknown effect(s) {', '.join(unknown)} of generator {generator!r}")


def critique_rates(
    config: str | PathLike[str],
    plan: str | PathLike[str],
    generator: str,
    effects: Sequence[str],
    *,
    multiples: Sequence[float] = (1.0,),
    nests: Sequence[bool] = (False,),
    seeds: Sequence[int] = range(10),
    executor: Executor | None = None,
) -> pd.DataFrame:
    """The critique's verdict on campaigns of one generator, one row per campaign.

    Parameters
    ----------
    config, plan
        The cell TOML the generators take and the critique reads (with the generator's tool weight, :class:`RateGenerator`),
        and the plan CSV of the generators that take one (``beams``, ``twin``).
    generator
        A key of :data:`GENERATORS`.
    effects
        The generator's effects (``"none"`` for nothing planted), keys of its ``expected``.
    multiples
        Magnitudes, as multiples of each effect's default (``none`` runs once, at 0).
    nests
        With and/or without reference-nest readings.
    seeds
        The campaigns' seeds: the same seeds in every case.
    executor
        Runs the campaigns (:func:`~bayescal.design.parallel.seeded_map`; default a process pool).

    Returns
    -------
    pandas.DataFrame
        ``generator, effect, multiple, nests, seed, expected, causes, first, partners, alone, right, wrong_single``:
        ``first`` the first cause (``adequate`` without one), ``partners`` the candidates tied with it or contesting
        it; ``alone`` the expected verdict first with no partner (``unexplained`` the only cause; nothing named
        for ``adequate``); ``right`` the expected verdict first or among its partners; ``wrong_single`` a misfit
        whose first cause is wrong and has no partner.
    """
    from bayescal.cell.config import load_cell
    from bayescal.design.parallel import seeded_map

    check_case(generator, effects)
    cases = [(e, 0.0 if e == "none" else float(m)) for e in effects for m in ((0.0,) if e == "none" else multiples)]
    tasks = [(generator, e, m, bool(n), int(s)) for n in nests for e, m in cases for s in seeds]
    streams = [np.random.SeedSequence(task[-1]) for task in tasks]
    return pd.DataFrame.from_records(
        seeded_map(_one, tasks, streams, executor=executor, cell=load_cell(config), plan=str(plan))
    )


def _se(p: float, n: int) -> float:
    """The binomial standard error of a fraction ``p`` of ``n``."""
    return float(np.sqrt(p * (1 - p) / n))


def _ranges(seeds) -> str:
    """The seeds as runs of consecutive ones: ``0-9, 40-99``."""
    values = np.unique(np.asarray(seeds, dtype=int))
    breaks = np.flatnonzero(np.diff(values) > 1)
    starts, ends = values[np.r_[0, breaks + 1]], values[np.r_[breaks, len(values) - 1]]
    return ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in zip(starts, ends))


def rates(table: pd.DataFrame) -> pd.DataFrame:
    """Per generator, effect, multiple and nests: campaigns, seeds, and the fractions first-and-alone right, right
    counting ties, wrong single cause and adequate, each with its binomial SE (``*_se``)."""
    rows = []
    for key, group in table.groupby(["generator", "effect", "multiple", "nests"], sort=False):
        n = len(group)
        row = dict(zip(("generator", "effect", "multiple", "nests"), key)) | {
            "expected": group["expected"].iloc[0], "n": n, "seeds": _ranges(group["seed"])}
        for name, values in (("alone", group["alone"]), ("right", group["right"]), ("wrong_single", group["wrong_single"]),
                             ("adequate", group["first"] == ADEQUATE)):
            p = float(np.mean(values))
            row |= {name: p, f"{name}_se": _se(p, n)}
        rows.append(row)
    return pd.DataFrame.from_records(rows)


def confusion(table: pd.DataFrame) -> pd.DataFrame:
    """Per case, what came first: ``first`` (with ``+``-joined partners after ``~``) and how many campaigns."""
    partners = table["partners"].fillna("")  # a table read back from CSV has NaN for no partner
    labels = table["first"] + np.where(partners != "", "~" + partners, "")
    frame = table.assign(named=labels).groupby(["generator", "effect", "multiple", "nests", "named"], sort=False).size()
    return frame.rename("campaigns").reset_index().sort_values(
        ["generator", "effect", "multiple", "nests", "campaigns"], ascending=[True, True, True, True, False], kind="stable"
    )


def markdown_rates(table: pd.DataFrame) -> str:
    """:func:`rates` and :func:`confusion` as one Markdown table, fractions in percent ± SE."""
    named = confusion(table)
    lines = ["| generator | planted | × default | nests | expected | campaigns (seeds) | first and alone | right (ties) "
             "| wrong single | adequate | named first |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rates(table).itertuples():
        mine = named[(named.generator == row.generator) & (named.effect == row.effect) & (named.multiple == row.multiple)
                     & (named.nests == row.nests)]
        first = ", ".join(f"`{r.named}` {r.campaigns}" for r in mine.itertuples())
        cells = [f"{100 * getattr(row, k):.0f} ± {100 * getattr(row, k + '_se'):.0f} %" for k in ("alone", "right", "wrong_single", "adequate")]
        lines.append(f"| {row.generator} | {row.effect} | {row.multiple:g} | {'yes' if row.nests else 'no'} | {row.expected} "
                     f"| {row.n} ({row.seeds}) | " + " | ".join(cells) + f" | {first} |")
    return "\n".join(lines)
