"""Plans that tell two candidate models apart: the experiment that resolves a tie of the critique.

When the critique finds two extensions of the classical model (say ``backlash``
and ``nonlinear_stiffness``) that explain a campaign equally well, the campaign
cannot tell them apart (``tied_with``).  A plan that can is one on which the two
models, each sized as the tied campaign says, predict the most different
deflections, measured in the tracker's noise.

The criterion, the smaller of the two models' expected log-likelihood ratios on the
plan's data, and the held-out ΔELPD it is expected to give in its standard errors, are
:mod:`bayescal.design.separation`'s.

The search (:mod:`bayescal.design.discriminating_search`) is Fedorov's exchange over a candidate set, as
:class:`~bayescal.design.optimise.PlanDesigner`'s, with one difference: each
candidate configuration comes at several masses across the design's range, and
a plan may load one configuration at two masses, since a lost motion is an
offset in the load and a torque-dependent compliance a curvature in it.

The order of measurement.  A lost motion shows where a load takes a joint to
the other side of its play, and which side a joint rests on depends on what
came before: on the friction that holds it and on how the servo brought it
there, neither known beforehand.  Within a q2 group the plan joint is not
driven, so its side is set by the loads alone.  The plan's groups are measured
in increasing q2 and each group's configurations alternate the side the load
takes the plan joint to, from a positive torque: the joint arrives driven up,
on the side a negative torque takes it to, and every configuration's first
loading reverses the previous state's, however the joint is held and however it
arrived.  The criterion counts that first loading from the far side of the play
(:data:`~bayescal.critique.covariates.REVERSED_MARKER`) and the repeats after it
as repeats.  Measured as a plan's candidates alone, without that order, the
designed plans separated the independent generator's tied lost motion taken up
on the side last driven to in 7 of 15 campaigns; ordered, 9 of 15; ordered and
counted, 13 of 15 (``docs/critique.md``; 5 × 6 plans, measured before commit
1adf04f, while the search scored options at other candidates' configurations).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan, write_plan
from bayescal.critique.compare import fit
from bayescal.critique.covariates import REVERSED_MARKER, Rows, campaign_rows, pose_rows
from bayescal.critique.extensions import CATALOGUE, PLANNABLE, Extension, base_columns
from bayescal.critique.model import fitted_variant
from bayescal.design.constraints import DesignSpace, load_design_space
from bayescal.design.discriminating_search import _Exchange
from bayescal.design.optimise import PlanDesigner
from bayescal.design.separation import Discrimination, plan_z, separation
from bayescal.errors import InputError
from bayescal.inference.identifiability import independent_columns
from bayescal.units import DEG

__all__ = ["DISCRIMINATE", "PER_ANGLE", "MASS_LEVELS", "DiscriminatingDesign", "DiscriminatingDesigner"]

DISCRIMINATE = "discriminate"
"""The criterion's name on the command line."""

PER_ANGLE = 12
"""Configurations per q2 angle of a discriminating plan by default: 5 × 12 at 3 repeats, four times Table III's.
On campaigns where lost motion and a torque-dependent compliance tie, 5 × 12 plans separated the twin's in
28 of 29 and 30 of 30, and the independent generator's lost motion with memory, its knee and its lost motion
on the side last driven to in 17 of 19, 23 of 28 and 17 of 24 (the slow test's 30 seeds; the size was chosen
on rates measured before commit 1adf04f; ``bayescal_studies.studies.discrimination``, docs/critique.md)."""

MASS_LEVELS = 4
"""Masses each candidate configuration is offered at, evenly over the design's range: two tell an
offset from a slope, a third and fourth a slope from a curvature."""

CANDIDATES_PER_ANGLE = 8
"""Candidate configurations per q2 angle of the grid (about 460 on the KR-270, each at :data:`MASS_LEVELS` masses)."""

STARTS = 4
"""Random starts of the exchange (its passes: :data:`~bayescal.design.discriminating_search.MAX_PASSES`)."""


def _columns(rows: Rows, cell: Cell, extension: Extension) -> np.ndarray:
    return extension.regressors(rows, cell).reshape(3 * len(rows), -1)




@dataclass(frozen=True)
class DiscriminatingDesign:
    """A plan designed to separate two candidates, and how well it and the tied campaign do.

    Attributes
    ----------
    plan : Plan
        ``angles × per_angle`` configurations grouped by q2, each with its own mass.
    planned, campaign : Discrimination
        The plan's separation and that of the tied campaign's own configurations, at the same repeats.
    magnitudes : dict
        Each candidate's coefficients fitted to the tied campaign (SI, in the catalogue's columns).
    repeats : int
    starts : list of float
        The worse separation (nats) reached from each random start.
    plan_joint : int
        Index (0-based) of the joint whose load each configuration reverses, in the plan's order.
    seed : int or None
    """

    plan: Plan
    planned: Discrimination
    campaign: Discrimination
    magnitudes: dict
    repeats: int
    starts: list
    plan_joint: int
    seed: int | None = None

    @property
    def order(self) -> str:
        """How the plan must be measured for its separation to hold."""
        return (
            f"measure the configurations in the order written, each one's repeats in a row: each load takes joint "
            f"{self.plan_joint + 1} to the other side of its play from the previous one's, where the configurations allow"
        )

    def summary(self) -> pd.DataFrame:
        """One row per configuration: joint angles (deg) and load (kg)."""
        table = pd.DataFrame(self.plan.q / DEG, columns=[f"q{j + 1}_deg" for j in range(self.plan.q.shape[1])])
        table["load_kg"] = self.plan.load_kg
        return table

    def document(self, output: str, campaign: str):
        """The plan as one document (:mod:`bayescal.summary`), what ``bayescal plan --criterion discriminate`` prints: ``output``
        names the file it was written to, ``campaign`` the tied campaign (:func:`~bayescal.design.document.discrimination_document`)."""
        from bayescal.design.document import discrimination_document

        return discrimination_document(self, output, campaign)

    def diagnostics(self) -> dict:
        return {"starts_worst_nats": [round(v, 3) for v in self.starts]}

    def to_json(self) -> dict:
        a, b = self.planned.between
        return {
            "optimised_for": DISCRIMINATE,
            "between": [a, b],
            "planned": self.planned.to_json(),
            "tied_campaign": self.campaign.to_json(),
            "meaning": "expected log-likelihood ratio (nats) of the true model over the other on the plan's data, "
            "each model sized by its fit to the tied campaign; a held-out ΔELPD estimates it",
            "configurations": len(self.plan),
            "repeats": self.repeats,
            "q2_deg": sorted({round(float(v), 3) for v in self.plan.q[:, 1] / DEG}),
            "load_kg": [round(float(m), 1) for m in self.plan.load_kg],
            "seed": self.seed,
            "order": self.order,
        } | self.diagnostics()

    def save(self, path: str | PathLike[str], *, comments: tuple[str, ...] = ()) -> None:
        a, b = self.planned.between
        note = (
            f"plan to tell {a} from {b}: {self.planned.worst:.1f} nats and {min(self.planned.z):.1f} SE expected at worst, "
            f"the tied campaign {self.campaign.worst:.1f} nats and {min(self.campaign.z):.1f} SE"
        )
        write_plan(self.plan, path, comments=(note, self.order) + tuple(comments))


class DiscriminatingDesigner:
    """Design the plan that best separates two candidates of the critique's catalogue on a tied campaign.

    Parameters
    ----------
    cell
        The cell.
    between
        The two candidates, names of :data:`~bayescal.critique.extensions.CATALOGUE` with columns.
    campaign
        The campaign on which they tie: each is sized by its fit to it.
    space
        The design space (joint limits, masses, tracker visibility); default the cell's.
    repeats
        Measurements of each configuration.
    """

    def __init__(self, cell: Cell, between: tuple[str, str], campaign: Campaign, space: DesignSpace | None = None, *, repeats: int = 3) -> None:
        if len(between) != 2 or between[0] == between[1]:
            raise InputError(f"expected two different candidates, got {','.join(between)}", source="between")
        for name in between:
            if name not in PLANNABLE:
                raise InputError(f"unknown candidate '{name}'; expected two of {', '.join(PLANNABLE)}", source="between")
        self.cell, self.between, self.repeats = cell, tuple(between), repeats
        self.space = load_design_space(cell) if space is None else space
        self.campaign = campaign

    def _design(self, rows: Rows, variants: tuple[Extension, Extension]) -> tuple[np.ndarray, tuple[slice, slice, slice]]:
        blocks = [base_columns(rows, self.cell).reshape(3 * len(rows), -1)] + [_columns(rows, self.cell, e) for e in variants]
        edges = np.cumsum([0] + [b.shape[1] for b in blocks])
        return np.hstack(blocks), tuple(slice(edges[i], edges[i + 1]) for i in range(3))

    def _information(self, rows: Rows, Z: np.ndarray, per: np.ndarray, repeats: int) -> np.ndarray:
        """(K, p, p) the information of each of the K groups of rows labelled ``per`` (0..K-1), each read ``repeats`` times."""
        sigma2 = 2.0 * np.repeat(self.cell.tracker.sigma(rows.position), 3) ** 2
        weighted = Z / sigma2[:, None]
        label = np.repeat(per, 3)
        # each group's rows in their order, from one stable sort: a mask over all the rows per group took 0.26 s of the 5 × 12
        # design's 6.2 s under the profiler
        order = np.argsort(label, kind="stable")
        edges = np.searchsorted(label[order], np.arange(per.max() + 2))
        return np.array([repeats * Z[order[a:b]].T @ weighted[order[a:b]] for a, b in zip(edges[:-1], edges[1:])])

    def optimise(
        self,
        angles: int = 5,
        per_angle: int = PER_ANGLE,
        rng: np.random.Generator | int | None = None,
        *,
        starts: int = STARTS,
        candidates_per_angle: int = CANDIDATES_PER_ANGLE,
    ) -> DiscriminatingDesign:
        """The plan of ``angles × per_angle`` configurations that best separates the two candidates.

        ``starts`` random starts of the exchange, ``candidates_per_angle`` candidate
        configurations at each q2 of the grid; the same seed gives the same plan.
        """
        seed = rng if isinstance(rng, int) else None
        rng = np.random.default_rng(rng)
        designer = self._checked_designer(angles, per_angle, candidates_per_angle)
        grid, configurations, index, _, _ = designer.candidates(rng, per_angle=candidates_per_angle)
        masses = np.linspace(*self.space.mass_range, MASS_LEVELS)
        markers = np.array(list(self.cell.markers.values()))
        # candidate c at mass level l is option c·L + l; one row per marker
        option = np.repeat(np.arange(len(configurations) * MASS_LEVELS), len(markers))
        q = configurations[option // MASS_LEVELS]
        # one wrench an option, the same on each of its markers' rows
        each = [self.cell.load_wrench(configurations[o // MASS_LEVELS], masses[o % MASS_LEVELS]) for o in range(option[-1] + 1)]
        wrench = np.repeat(np.array(each), len(markers), axis=0)
        pool = pose_rows(self.cell, q, wrench, np.tile(markers, (len(configurations) * MASS_LEVELS, 1)), config=option)
        # the first loading of each candidate, measured after a load that took the plan joint the other way
        first = replace(pool, marker=np.full(len(pool), REVERSED_MARKER))
        measured = campaign_rows(self.cell, self.campaign)
        # one design for the campaign and the pool, so that columns scaled by their rows (backlash) scale alike
        # each candidate at the setting (a lost motion's friction hold) the tied campaign supports best
        variants = tuple(fitted_variant(self.cell, measured, CATALOGUE[name])[0] for name in self.between)
        Z, blocks = self._design(measured.extend(pool).extend(first), variants)
        n, m = 3 * len(measured), 3 * len(pool)
        beta = self._magnitudes(measured, Z[:n], blocks)
        _, labels = np.unique(measured.config, return_inverse=True)
        # the campaign's rows are its readings, every repeat already one of them
        tied = self._information(measured, Z[:n], labels, 1)
        information = self._information(first, Z[n + m :], option, 1) + self._information(pool, Z[n : n + m], option, self.repeats - 1)
        group = np.repeat(index, MASS_LEVELS)
        # the side each option's load leaves the plan joint at: the sign of that joint's loaded torque
        side = np.sign((pool.static_torque + pool.load_torque)[:: len(markers), pool.plan_joint])
        search = _Exchange(information, group, side, grid, self.space.min_separation, blocks, beta, rng)
        best, reached = None, []
        for _ in range(starts):
            chosen, score = search.run(angles, per_angle)
            reached.append(score)
            if best is None or score > best[1]:
                best = (chosen, score)
        # q2 groups in increasing angle, each in the order of its slots: loads alternating the plan joint's side
        order = np.array(sorted(best[0], key=lambda o: grid[group[o]]))
        plan = Plan(
            q=configurations[order // MASS_LEVELS], load_kg=masses[order % MASS_LEVELS], lines=np.zeros(len(order), dtype=int), source="optimised"
        )
        return self._design_of(plan, information[order], tied, (blocks, beta), reached, pool.plan_joint, seed)

    def _checked_designer(self, angles: int, per_angle: int, candidates_per_angle: int) -> PlanDesigner:
        """The linear plan designer whose candidates the search draws from, refusing a request it cannot meet."""
        designer = PlanDesigner(self.cell, self.space, repeats=self.repeats, model="linear")
        if angles < 1 or angles > designer.max_angles():
            raise InputError(f"expected 1 to {designer.max_angles()} angles, got {angles}", source="angles")
        if not 1 <= per_angle <= candidates_per_angle * MASS_LEVELS:
            raise InputError(
                f"expected 1 to {candidates_per_angle * MASS_LEVELS} configurations per q2 angle (the {candidates_per_angle} candidates "
                f"the design draws at each, at {MASS_LEVELS} masses), got {per_angle}",
                source="per_angle",
            )
        return designer

    def _design_of(self, plan: Plan, planned: np.ndarray, tied: np.ndarray, fitted: tuple, reached: list[float], plan_joint: int,
                   seed: int | None) -> DiscriminatingDesign:
        """The chosen plan with the separation it and the tied campaign give each pair of candidates."""
        blocks, beta = fitted
        between = self.between
        return DiscriminatingDesign(
            plan=plan,
            planned=_discrimination(between, planned, blocks, beta),
            campaign=_discrimination(between, tied, blocks, beta),
            magnitudes={name: b.tolist() for name, b in zip(between, beta)},
            repeats=self.repeats,
            starts=reached,
            plan_joint=plan_joint,
            seed=seed,
        )

    def _magnitudes(self, rows: Rows, Z: np.ndarray, blocks) -> tuple[np.ndarray, np.ndarray]:
        """Each candidate's coefficients fitted, on top of the classical model, to the tied campaign (0 for columns it cannot fit)."""
        y = rows.y.reshape(-1)
        scale, group = np.repeat(rows.noise, 3), np.tile(np.arange(3), len(rows))
        out = []
        for own in blocks[1:]:
            columns = np.concatenate([np.arange(Z.shape[1])[blocks[0]], np.arange(Z.shape[1])[own]])
            kept = columns[independent_columns(Z[:, columns])]
            fitted = fit(y, Z[:, kept], scale, group)
            beta = np.zeros(Z.shape[1])
            beta[kept] = fitted.beta
            out.append(beta[own])
        return out[0], out[1]


def _discrimination(between: tuple[str, str], information: np.ndarray, blocks, beta) -> Discrimination:
    """The separation of a plan whose configurations have information ``information`` (K, p, p)."""
    nats = separation(information.sum(axis=0), blocks, *beta)
    return Discrimination(between, tuple(float(v) for v in nats), tuple(float(v) for v in plan_z(information, blocks, *beta)))
