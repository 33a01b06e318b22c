"""Model criticism of the classical VJM model: what it gets wrong, the likely cause, and the gain of fixing it.

``Critique(cell).run(campaign)`` starts from the classical serial VJM model
(eq 30 with one constant compliance per joint and one unknown noise level per
base axis) and adds, greedily, the extension of
:data:`~bayescal.critique.extensions.CATALOGUE` that best predicts held-out
configurations, as long as its gain is clear of its uncertainty
(:mod:`bayescal.critique.rule`: :data:`~bayescal.critique.rule.DETECTION_Z` standard errors and
:data:`~bayescal.critique.rule.DETECTION_FLOOR` nats, or :data:`~bayescal.critique.rule.DECISIVE_GAIN`
nats and :data:`~bayescal.critique.rule.DECISIVE_Z` standard errors: no clause names a
gain within its own standard error).
A candidate that also passes and that the named one does not beat held out ties with it or contests it,
unless the named one explains it (:func:`~bayescal.critique.rule.explains`: the rival adds nothing on top of
it, it still adds on top of the rival).  A heavy tail (``outliers``, gross tracker errors, one reading at a time)
that predicts the held-out configurations better shared by every marker of a state is the arm's misfit, not the
tracker's: it is not named (:func:`_shared_by_state`).  Where the search stops and the repeats' lack of fit
(:mod:`bayescal.critique.repeats`) says the model still misses them, a physical candidate clear of one standard error
with which the repeats are fitted is named by them (:func:`_by_repeats`).
Each named cause is measured by what it changes for the user (:meth:`Critique.run`'s
``importance``: the held-out residual rms and the prediction at the test pose), and a
cause that changes neither by more than the calibration's own uncertainty at the test
pose is reported as detectable but too small to matter.  ``drift`` is tried only where
the campaign's readings repeated in time can show it (:mod:`bayescal.critique.drift`).
When no extension passes any more, the residual offsets of
:data:`~bayescal.critique.extensions.PROBES` are tried by the same rule
(without the decisive branch, since their many free offsets can fit a few odd
configurations): one
that passes is a misfit the catalogue does not explain, reported as the
cause ``unexplained`` with the covariate it follows.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.cell.config import Cell
from bayescal.cell.nests import Nests, require_times
from bayescal.critique.checks import residual_summary, residual_table
from bayescal.critique.compare import Comparison, CrossValidation, chosen, compare, cross_validate, fit
from bayescal.critique.covariates import Rows, campaign_rows, pose_rows
from bayescal.critique.drift import MAKE_TESTABLE, DriftEvidence, drift_deflection, drift_evidence
from bayescal.critique.extensions import CATALOGUE, PROBES, Extension, base_columns
from bayescal.critique.repeats import RepeatsCheck
from bayescal.critique.results import CritiqueResults
from bayescal.critique.rule import DETECTION_Z, UNEXPLAINED, accounts_for, check_candidates, explains, passes, separable, shows, strongest
from bayescal.errors import InputError
from bayescal.inference.equations import check_campaign
from bayescal.inference.identifiability import independent_columns
from bayescal.inference.lack_of_fit import LackOfFit
from bayescal.threads import one_blas_thread
from bayescal.units import MM

__all__ = ["Critique", "fitted_variant"]

MIN_CONFIGURATIONS = 4
"""Fewest configurations a held-out comparison can rest on (the SE of the difference needs several)."""


@dataclass(frozen=True)
class _Model:
    extensions: tuple[Extension, ...]

    @property
    def robust(self) -> bool:
        return any(e.robust for e in self.extensions)

    def units(self, rows: Rows) -> np.ndarray | None:
        """(3N,) the Student-t noise's mixing unit of each equation: a state's rows together where an extension asks it,
        else None (each row, :func:`~bayescal.critique.compare.fit`)."""
        if not any(e.per_state for e in self.extensions):
            return None
        return np.repeat(np.unique(np.column_stack([rows.config, rows.repeat]), axis=0, return_inverse=True)[1].reshape(-1), 3)

    def design(self, rows: Rows, cell: Cell) -> np.ndarray:
        return self.blocks(rows, cell)[0]

    def blocks(self, rows: Rows, cell: Cell) -> tuple[np.ndarray, np.ndarray]:
        """(3N, p) the design, and (p,) which of its columns predict at other poses (the base's and the physical extensions')."""
        blocks = [base_columns(rows, cell)] + [e.regressors(rows, cell) for e in self.extensions]
        physical = np.concatenate([np.full(b.shape[2], e is None or e.physical) for b, e in zip(blocks, (None, *self.extensions))])
        return np.concatenate(blocks, axis=2).reshape(3 * len(rows), -1), physical

    def plus(self, extension: Extension) -> _Model:
        return _Model(self.extensions + (extension,))


@dataclass
class Critique:
    """Criticism of the classical VJM model on a campaign.

    Parameters
    ----------
    cell
        The cell: robot (kinematics, link masses for the torques the joints carry),
        compensator geometry, tool markers, tracker noise model, test pose.
    catalogue
        The extensions to try, by name; default all of :data:`CATALOGUE`.
    probes
        The covariates an unexplained misfit is checked against; default all of :data:`PROBES`.
    """

    cell: Cell
    catalogue: tuple[str, ...] = tuple(CATALOGUE)
    probes: tuple[str, ...] = tuple(PROBES)

    def __post_init__(self) -> None:
        check_candidates(self.catalogue, CATALOGUE)
        check_candidates(self.probes, PROBES)

    def run(self, campaign: Campaign, rng: np.random.Generator | int | None = None, nests: Nests | None = None,
            repeats: bool = False) -> CritiqueResults:
        """Criticise the classical model on ``campaign``; with ``nests`` (or ``repeats``: from the repeat groups alone),
        after removing the drift they measure.

        With reference-nest readings the tracker's drift is measured from them (and the campaign's repeat groups
        with ``repeats``: :mod:`bayescal.registration.repeats`), taken out of the readings with its uncertainty added to the
        deflections, and reported: it is then no candidate.  ``nests`` needs the campaign's reading times.  The
        critique keeps the posterior mean's removal with a variance per row where ``calibrate`` integrates over draws of
        the drift: its findings are the candidates' held-out predictive comparisons and the residuals' checks, not
        intervals that pooling fits could widen (docs/critique.md, *Drift*).

        ``rng`` is accepted for the command line's ``--seed``; the critique itself is
        deterministic (closed-form predictive densities, no sampling).  BLAS runs on one
        thread meanwhile (:func:`~bayescal.threads.one_blas_thread`): the folds' normal
        equations are sums of a few hundred equations each: on the 2-core development machine
        the demo's critique took 0.4-1.6 s (four runs) with BLAS's default two threads, 0.15 s with one.
        """
        measured = None
        if nests is not None or repeats:
            # here, not at the module's top: the registration package loads SciPy's optimiser, which a critique
            # without drift evidence never needs (a tenth of the demo's critique)
            from bayescal.registration.repeats import fit_drift

            require_times(campaign.times, campaign.source, "nests" if nests is not None else "repeats", nests)
            track = fit_drift(campaign, self.cell.tracker, nests, repeats=repeats)
            if track is None:
                raise InputError("no marker's state is read twice at different times: " + MAKE_TESTABLE, source=campaign.source)
            measured = track.to_json(campaign) | {"testable": True, "candidate": False}
            campaign = track.remove(campaign)
        with one_blas_thread():
            return self._run(campaign, measured)

    def _run(self, campaign: Campaign, measured: dict | None = None) -> CritiqueResults:
        n_configs = self._checked_size(campaign)
        rows = campaign_rows(self.cell, campaign)
        # markers located on the tool at the measured unloaded pose, so that a sagging arm is no mislabelled marker
        check_campaign(self.cell.robot, campaign, rows.point, hanging_only=self.cell.loading.hanging_only)
        y = rows.y.reshape(-1)
        scale = np.repeat(rows.noise, 3)
        group = np.tile(np.arange(3), len(rows))
        validate = _validation(rows, self.cell)

        def fitted(model: _Model, cv: CrossValidation) -> np.ndarray:
            return cv.full.predict(model.design(rows, self.cell)[:, cv.columns])

        base = validate(_Model(()))
        # measured drift is removed already, not a candidate; without readings that can show a drift, a drift fitted to
        # the deflections would be a catch-all
        drift = None if measured is not None else drift_evidence(rows, self.cell, fitted="drift" in self.catalogue)
        remaining = [CATALOGUE[name] for name in self.catalogue if name != "drift" or (drift is not None and drift.testable)]
        noise_of = lambda cv: cv.full.level[group] * scale  # noqa: E731 - each equation's fitted noise sd
        search = _greedy_search(base, remaining, validate, fitted, noise_of)
        check = RepeatsCheck.of(self.cell, campaign, rows)
        misfit = _by_repeats(search, remaining, validate, lambda model: check(model.design(rows, self.cell)), fitted, noise_of)
        model, current, causes, final = search.model, search.current, search.causes, search.judged
        probes = {name: compare(current, validate(model.plus(PROBES[name]))) for name in self.probes}
        covariate = strongest(probes, decisive=False)
        # The repeats' pure error sees a misfit of any shape, also one no candidate matches; a robust
        # model's outliers inflate both sides of the test, so it does not overrule a named outlier model.
        unmatched = misfit is not None and misfit.significant() and not model.robust
        if covariate is not None or unmatched or search.arm_misfit:
            causes.append(UNEXPLAINED)
        equation_rows = np.repeat(np.arange(len(rows)), 3)
        return CritiqueResults(
            causes=causes,
            unexplained_covariate=covariate,
            steps=search.steps,
            probes=probes,
            base=base,
            final=final,
            gain=compare(base, final),
            before=residual_summary(y, base, equation_rows),
            after=residual_summary(y, final, equation_rows),
            test_pose=self._test_pose(model, rows, y, scale, group),
            n_configs=n_configs,
            n_equations=y.size,
            residuals=residual_table(rows, y, base, final),
            source=campaign.source,
            lack_of_fit=misfit,
            tied_with={cause: others for cause, others in search.tied.items() if others},
            contested_by={cause: others for cause, others in search.contested.items() if others},
            explains={cause: others for cause, others in search.explained.items() if others},
            shared_by_state=search.shared_by_state,
            by_repeats=search.by_repeats,
            settings={e.name: e.reading(rows, self.cell) for e in model.extensions if e.setting is not None},
            importance=self._importance(search.history, rows, y, scale, group, equation_rows),
            drift=measured or _drift_report(drift, rows, "drift" in self.catalogue),
        )

    def _checked_size(self, campaign: Campaign) -> int:
        """The campaign's number of configurations, refusing too few of them or joints that are not the robot's."""
        n_configs = np.unique(campaign.config).size
        if n_configs < MIN_CONFIGURATIONS:
            raise InputError(
                f"the critique compares models on held-out configurations and needs at least {MIN_CONFIGURATIONS}, got {n_configs}",
                source=campaign.source,
            )
        if campaign.q.shape[1] != self.cell.robot.nq:
            raise InputError(
                f"the campaign has {campaign.q.shape[1]} joint angles per row, the cell's robot {self.cell.robot.nq}",
                source=campaign.source,
            )
        return n_configs

    def discriminate(self, campaign: Campaign, a: str, b: str) -> Comparison:
        """Held-out comparison of the classical model plus ``b`` against it plus ``a`` on ``campaign``.

        The question a plan of :mod:`bayescal.design.discriminate` was measured to
        answer: ``delta_elpd > DETECTION_Z · se`` says ``b`` predicts the campaign's
        held-out configurations better than ``a``, a negative one the reverse.
        """
        check_candidates((a, b), CATALOGUE)
        rows = campaign_rows(self.cell, campaign)
        return compare(*(fitted_variant(self.cell, rows, CATALOGUE[name])[1] for name in (a, b)))

    def _test_prediction(self, model: _Model, rows: Rows, y, scale, group) -> tuple[np.ndarray, np.ndarray]:
        """Deflection (3,) of the cell's test point the model predicts, and its sd (3,), m.

        Fitted with all its columns, predicted with the physical ones only: a drift or a probe is
        removed from the campaign, not carried to the test pose.
        """
        cell = self.cell
        test = pose_rows(cell, cell.test_q, cell.test_wrench, cell.test_point)
        X = model.design(rows, cell)
        cv_columns = independent_columns(X)
        fitted = fit(y, X[:, cv_columns], scale, group, robust=model.robust, unit=model.units(rows))
        # with the campaign's rows, so that columns scaled by the campaign (backlash) scale alike
        design, physical = model.blocks(rows.extend(test), cell)
        X0 = design[-3:] * physical
        mean = X0[:, cv_columns] @ fitted.beta
        # Joints the campaign does not excite (k1 under vertical loads) keep the cell's compliance.
        dropped = np.setdiff1d(np.arange(cell.robot.nq), cv_columns[cv_columns < cell.robot.nq])
        mean = mean + X0[:, dropped] @ cell.compliances[dropped]
        sd = np.sqrt(np.einsum("ij,jk,ik->i", X0[:, cv_columns], fitted.cov, X0[:, cv_columns]))
        return mean, sd

    def _test_pose(self, model: _Model, rows: Rows, y, scale, group) -> dict:
        """Deflection of the cell's test point predicted by the classical and by the extended model, mm."""
        out = {}
        for name, m in (("classical", _Model(())), ("extended", model)):
            mean, sd = self._test_prediction(m, rows, y, scale, group)
            out[name] = {"deflection_mm": (mean / MM).tolist(), "sd_mm": (sd / MM).tolist()}
        difference = np.array(out["extended"]["deflection_mm"]) - np.array(out["classical"]["deflection_mm"])
        out["classical_error_mm"] = float(np.linalg.norm(difference))
        out["note"] = "classical_error_mm: the error the classical model leaves at the test pose if the extended model is right"
        return out

    def _importance(self, history: list[tuple[_Model, CrossValidation]], rows: Rows, y, scale, group, equation_rows) -> dict:
        """What each named cause changes for the user: the held-out residual rms, and the prediction at the test pose.

        A cause *matters* when it moves the test pose's prediction, or explains a misfit across the
        campaign's configurations (``sqrt(rms_before² - rms_after²)`` of the held-out residuals), by more
        than the calibration's own uncertainty at the test pose (the norm of the prediction's sd with the
        cause): below it, compensating for the cause moves the arm by less than the calibration already
        leaves uncertain.
        """
        out = {}
        predictions = [self._test_prediction(m, rows, y, scale, group) for m, _ in history]
        for k in range(1, len(history)):
            name = history[k][0].extensions[-1].name
            before = residual_summary(y, history[k - 1][1], equation_rows)["residual_rms_mm"]
            after = residual_summary(y, history[k][1], equation_rows)["residual_rms_mm"]
            moved = float(np.linalg.norm(predictions[k][0] - predictions[k - 1][0]) / MM)
            explained = float(np.sqrt(max(before**2 - after**2, 0.0)))
            uncertainty = float(np.linalg.norm(predictions[k][1]) / MM)
            out[name] = {
                "residual_rms_mm": [round(before, 5), round(after, 5)],
                "explained_misfit_rms_mm": round(explained, 5),
                "test_pose_change_mm": round(moved, 5),
                "test_pose_sd_mm": round(uncertainty, 5),
                "matters": bool(moved > uncertainty or explained > uncertainty),
            }
        return out


@dataclass
class _Search:
    """The greedy search's end: the final model and its held-out scores, the causes in order, each cause's ties,
    contests and the rivals it explains (with both comparisons of :func:`_explained`), every step's evidence and the
    models along the way."""

    model: _Model
    current: CrossValidation
    causes: list[str]
    tied: dict[str, list[str]]
    contested: dict[str, list[str]]
    explained: dict[str, dict[str, tuple[Comparison, Comparison]]]
    shared_by_state: dict[str, Comparison]
    steps: list[dict[str, Comparison]]
    history: list[tuple[_Model, CrossValidation]]
    arm_misfit: bool = False
    """Whether the last step refused a heavy tail the markers of a state share: a misfit no candidate named."""
    by_repeats: dict[str, tuple[LackOfFit, LackOfFit]] = field(default_factory=dict)
    """The cause named because it accounts for the misfit the repeats reveal (:func:`_by_repeats`), with the lack of
    fit without it and with it."""
    optimism: np.ndarray | float = 0.0
    """(K,) what the named causes' variants of largest held-out total add to ``current``'s log predictive densities
    over the same causes with their variants integrated out (:func:`~bayescal.critique.compare.chosen`)."""

    def name(self, cause: str, extension: Extension, judged: CrossValidation, validate: Callable[[_Model], CrossValidation]) -> None:
        """Add ``cause`` at its variant ``extension``, judged by ``judged``; the next step's models keep the variant."""
        self.model = self.model.plus(extension)
        self.current = validate(self.model)
        self.optimism = self.optimism + (self.current.elpd - judged.elpd)
        self.causes.append(cause)
        self.history.append((self.model, self.current))

    @property
    def judged(self) -> CrossValidation:
        """The final model's cross-validation with its causes' variants integrated out: the gain it reports."""
        return replace(self.current, elpd=self.current.elpd - self.optimism)


def _greedy_search(base: CrossValidation, remaining: list[Extension], validate: Callable[[_Model], CrossValidation],
                   fitted: Callable[[_Model, CrossValidation], np.ndarray], noise_of: Callable[[CrossValidation], np.ndarray]) -> _Search:
    """Add the strongest candidate while one passes the rule, each on top of those before."""
    search = _Search(_Model(()), base, [], {}, {}, {}, {}, [], [(_Model(()), base)])
    while remaining:
        model, current = search.model, search.current
        trials = {e.name: _best_variant(e, model, validate) for e in remaining}
        evidence = {name: compare(current, cv) for name, (_, cv) in trials.items()}
        search.steps.append(evidence)
        shared = _shared_by_state(trials, evidence, model, validate)
        search.shared_by_state |= shared
        search.arm_misfit = bool(shared)
        trials = {name: trial for name, trial in trials.items() if name not in shared}
        evidence = {name: comparison for name, comparison in evidence.items() if name in trials}
        best = strongest(evidence)
        if best is None:
            break
        search.tied[best], contested = _rivals(
            best, trials, evidence, lambda name: fitted(model.plus(trials[name][0]), trials[name][1]), noise_of(current)
        )
        search.explained[best] = _explained(best, contested, model, trials, remaining, validate)
        search.contested[best] = [name for name in contested if name not in search.explained[best]]
        search.name(best, *trials[best], validate)
        remaining = [e for e in remaining if e.name != best]
    return search


def _shared_by_state(trials: dict, evidence: dict[str, Comparison], model: _Model,
                     validate: Callable[[_Model], CrossValidation]) -> dict[str, Comparison]:
    """The robust candidates that pass, but whose heavy tail the markers of a state share: each with the held-out
    comparison of the same tail per state against its tail per reading (positive: the state's is better).

    Gross tracker errors put single readings off, one marker at a time; an arm that is not where the model puts it
    (a joint's play on the side the model did not predict) moves every marker read in that state together.  The unit
    the tail is shared by is chosen as the variant a candidate is fitted at is (:func:`_best_variant`), by the held-out
    density, with no constant of its own: where the tail shared by a state predicts the held-out configurations
    better, the misfit is the arm's, and a tracker-error model is no cause of it.  The candidate is then not named,
    and what it took up is left to the other candidates; where it is still there when the search ends, it is a misfit
    no candidate names (``unexplained``: the repeats' lack of fit cannot show it, since one repeat off inflates the
    repeats' own scatter).
    """
    out = {}
    for name, (variant, cv) in trials.items():
        if variant.robust and passes(evidence[name]):
            per_state = compare(cv, validate(model.plus(replace(variant, per_state=True))))
            if per_state.delta_elpd > 0:
                out[name] = per_state
    return out


def _by_repeats(search: _Search, candidates: list[Extension], validate: Callable[[_Model], CrossValidation],
                misfit_of: Callable[[_Model], LackOfFit | None], fitted: Callable[[_Model, CrossValidation], np.ndarray],
                noise_of: Callable[[CrossValidation], np.ndarray]) -> LackOfFit | None:
    """The final model's lack of fit against the repeats, after naming the candidate that accounts for a misfit they
    reveal where no candidate passed the rule (:func:`~bayescal.critique.rule.accounts_for`).

    Of the physical candidates of the search's last step that account for it, the one of largest held-out gain is
    named (``search`` extended in place, ``search.by_repeats`` recording the lack of fit without it and with it); those
    of the others it does not beat by :data:`~bayescal.critique.rule.DETECTION_Z` SE tie with it or contest it, as at a
    step of the search.  A robust model's outliers inflate both sides of the repeats' test: it is not asked there; nor
    where a drift is named or its held-out gain clears the same bar (:func:`~bayescal.critique.rule.shows`): on the
    independent generator's thermal drift, repeats back to back, the repeats' misfit a random walk's drift left had been given to
    ``backlash``, ``nonlinear_stiffness`` or ``tool_compliance`` (docs/critique.md, *Named by the repeats*).
    """
    misfit = misfit_of(search.model)
    # an empty catalogue has no step: nothing to name
    if misfit is None or not misfit.significant() or search.model.robust or not search.steps:
        return misfit
    model, evidence = search.model, search.steps[-1]
    # What of a drift its column does not follow (a 30 min cycle about a steady rate) is lack of fit too: where the
    # repeated readings show a drift, the repeats cannot speak for a physical candidate.
    unphysical = [e.name for e in (*model.extensions, *candidates) if not e.physical]
    if any(name in search.causes or (name in evidence and shows(evidence[name])) for name in unphysical):
        return misfit
    trials = {e.name: _best_variant(e, model, validate) for e in candidates
              if e.name in evidence and e.name not in search.causes and e.physical and not e.robust}
    misfits = {name: misfit_of(model.plus(variant)) for name, (variant, _) in trials.items()}
    accounting = [name for name, with_it in misfits.items() if accounts_for(evidence[name], with_it)]
    if not accounting:
        return misfit
    best = max(accounting, key=lambda name: evidence[name].delta_elpd)
    search.tied[best], search.contested[best] = _rivals(
        best, trials, evidence, lambda name: fitted(model.plus(trials[name][0]), trials[name][1]), noise_of(search.current),
        qualifies=lambda name: name in accounting,
    )
    search.name(best, *trials[best], validate)
    search.by_repeats[best] = (misfit, misfits[best])
    return misfits[best]


def _best_variant(extension: Extension, model: _Model, validate: Callable[[_Model], CrossValidation]) -> tuple[Extension, CrossValidation]:
    """The variant of ``extension`` (:meth:`~bayescal.critique.extensions.Extension.variants`) that, added to
    ``model``, predicts the held-out configurations best, and the candidate's cross-validation with its variant
    integrated out (:func:`~bayescal.critique.compare.chosen`): what judges the candidate.  The variant's own cross-validation,
    ``validate(model.plus(variant))``, is the baseline of what is added on top of it, which keeps the variant."""
    variants = extension.variants()
    index, cv = chosen([validate(model.plus(variant)) for variant in variants])
    return variants[index], cv


def fitted_variant(cell: Cell, rows: Rows, extension: Extension) -> tuple[Extension, CrossValidation]:
    """The variant of ``extension`` that, added alone to the classical model, best predicts the held-out
    configurations of ``rows`` (:func:`~bayescal.critique.covariates.campaign_rows`), and its cross-validation."""
    return _best_variant(extension, _Model(()), _validation(rows, cell))


def _validation(rows: Rows, cell: Cell) -> Callable[[_Model], CrossValidation]:
    """``validate(model)``: the model's left-one-configuration-out cross-validation on ``rows``, each model's kept
    (a contest's rival added on top of the named cause, :func:`_explained`, is the next step's trial of that rival)."""
    y = rows.y.reshape(-1)
    scale, group, config = np.repeat(rows.noise, 3), np.tile(np.arange(3), len(rows)), np.repeat(rows.config, 3)
    validated: dict[_Model, CrossValidation] = {}

    def validate(model: _Model) -> CrossValidation:
        if model not in validated:
            validated[model] = cross_validate(y, model.design(rows, cell), scale, group, config, robust=model.robust, unit=model.units(rows))
        return validated[model]

    return validate


def _rivals(best: str, trials: dict, evidence: dict[str, Comparison], fitted: Callable[[str], np.ndarray], noise: np.ndarray,
            qualifies: Callable[[str], bool] | None = None) -> tuple[list[str], list[str]]:
    """Candidates that also pass (or ``qualifies(name)``) and that ``best`` does not beat by :data:`~bayescal.critique.rule.DETECTION_Z` SE on held-out configurations:
    those tied with it, and those that contest it.

    Tied: their fitted deflections (``fitted(name)``, (3N,) m) differ from ``best``'s, in ``noise`` (3N,) m, by too little
    for any set of this plan's readings to name one over the other (:func:`~bayescal.critique.rule.separable`); they explain
    this campaign alike.  Contested: this plan could separate them, but the held-out scores did not (some configurations
    favour each, as a misfit that neither candidate explains makes them do).
    """
    tied, contested = [], []
    for name in trials:
        if name == best or not (qualifies(name) if qualifies is not None else passes(evidence[name])):
            continue
        lead = compare(trials[name][1], trials[best][1])
        if lead.delta_elpd > DETECTION_Z * lead.se:
            continue
        (contested if separable((fitted(name) - fitted(best)) / noise) else tied).append(name)
    return tied, contested


def _explained(best: str, contested: list[str], model: _Model, trials: dict, remaining: list[Extension],
               validate: Callable[[_Model], CrossValidation]) -> dict[str, tuple[Comparison, Comparison]]:
    """The rivals contesting ``best`` that it explains (:func:`~bayescal.critique.rule.explains`), each with the
    rival added on top of ``best`` and ``best`` added on top of the rival, both against ``model``'s step.

    The rival on top of ``best`` at its best variant there, as the search's next step adds it (that cross-validation
    is the next step's, kept by ``validate``); ``best`` on top of the rival at the variant it was named with.  Either
    choice, where a variant could differ, makes it harder to call a rival explained, never easier.
    """
    named = trials[best][0]
    extensions = {e.name: e for e in remaining}
    out = {}
    for name in contested:
        rival = trials[name][0]
        rival_added = compare(validate(model.plus(named)), _best_variant(extensions[name], model.plus(named), validate)[1])
        named_added = compare(validate(model.plus(rival)), validate(model.plus(rival).plus(named)))
        if explains(rival_added, named_added):
            out[name] = (rival_added, named_added)
    return out


def _drift_report(drift: DriftEvidence, rows: Rows, tried: bool) -> dict:
    """Whether the campaign can show a drift, what its repeated readings give, and the drift that puts into the deflections."""
    payload = drift.to_json() | {"candidate": tried and drift.testable}
    if drift.track is not None:
        mean, sd = drift_deflection(drift, rows)
        payload["deflection_rms_mm"] = round(float(np.sqrt(np.mean(mean**2)) / MM), 5)
        payload["deflection_sd_rms_mm"] = round(float(np.sqrt(np.mean(sd**2)) / MM), 5)
    return payload
