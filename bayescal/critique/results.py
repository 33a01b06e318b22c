"""What a critique found: :class:`Outcome` for any greedy critique, :class:`CritiqueResults` for the campaign's.

Plain data with the house's verbs (``summary()``, ``diagnostics()``, ``to_json()``, ``save()``);
:class:`~bayescal.critique.model.Critique` computes them.  :class:`CritiqueFindings` is what a critique's JSON
file holds, read back (the file keeps each candidate at its last step only: it cannot rebuild the results).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path

import pandas as pd

from bayescal.critique.compare import Comparison, CrossValidation
from bayescal.critique.covariates import COVARIATES
from bayescal.critique.rule import DECISIVE_GAIN, DECISIVE_Z, DETECTION_FLOOR, DETECTION_Z, SEPARABLE_CHI2
from bayescal.inference.lack_of_fit import LACK_OF_FIT_LEVEL, LackOfFit
from bayescal.jsonfiles import JsonFindings, JsonSchema
from bayescal.summary import Summary

__all__ = ["Outcome", "CritiqueResults", "CritiqueFindings", "CRITIQUE_JSON", "VERDICTS"]

VERDICTS = ("adequate", "misfit")
"""The verdicts a critique gives (:attr:`Outcome.verdict`)."""

SHARED_BY_STATE = ("a heavy tail shared by every marker of a state predicts the held-out configurations better than one "
                   "per reading: the arm is off in those states, not the tracker's readings; not named as gross errors")
"""What ``shared_by_state`` in the critique's JSON means."""

BY_REPEATS = ("the repeats showed a misfit no candidate passed the rule for; this one's held-out gain is clear of one "
              "standard error and the floor, not of the rule, and with it the repeats are fitted: it accounts for the misfit")
"""What ``by_repeats`` in the critique's JSON means."""

CRITIQUE_JSON = JsonSchema({"verdict": str, "causes": list, "evidence": dict, "gain": dict}, "bayescal critique --json",
                           foreign="parameters", values={"verdict": VERDICTS})
"""What a reader of :meth:`CritiqueResults.to_json`'s file relies on (the geometry critique's has the same keys);
``parameters`` is a calibration's key."""


def _candidate_summary(
    steps: list[dict[str, Comparison]], causes: list[str], probes: dict[str, Comparison], covariate: str | None
) -> pd.DataFrame:
    """One row per candidate and greedy step, then per covariate probe: held-out ΔELPD, its SE, and whether it was named."""
    records = []
    for step_number, step in enumerate(steps, start=1):
        for name, c in step.items():
            named = step_number <= len(causes) and causes[step_number - 1] == name
            records.append(
                {"candidate": name, "kind": "extension", "step": step_number, "delta_elpd_nats": c.delta_elpd, "se_nats": c.se, "named": named}
            )
    for name, c in probes.items():
        records.append(
            {"candidate": name, "kind": "covariate", "step": len(steps) + 1, "delta_elpd_nats": c.delta_elpd, "se_nats": c.se,
             "named": name == covariate}
        )
    return pd.DataFrame.from_records(records, columns=["candidate", "kind", "step", "delta_elpd_nats", "se_nats", "named"])


@dataclass
class Outcome:
    """What a greedy critique found: the causes it named and the evidence, step by step.

    Attributes
    ----------
    causes : list of str
        Extensions named, in the order added (each fitted on top of those before),
        then ``"unexplained"`` when a misfit remains that follows a covariate.
    unexplained_covariate : str or None
        The covariate the remaining misfit follows.
    steps : list of dict
        Per greedy step, every candidate's held-out comparison against the model so far.
    probes : dict
        Each covariate probe's comparison against the final model.
    """

    causes: list[str]
    unexplained_covariate: str | None
    steps: list[dict[str, Comparison]]
    probes: dict[str, Comparison]

    @property
    def verdict(self) -> str:
        return "misfit" if self.causes else "adequate"

    def summary(self) -> pd.DataFrame:
        """One row per candidate and greedy step, then per covariate probe: held-out ΔELPD, its SE, and whether it was named."""
        return _candidate_summary(self.steps, self.causes, self.probes, self.unexplained_covariate)


@dataclass
class CritiqueResults(Outcome):
    """What the campaign critique found (:class:`Outcome`, and the following).

    Attributes
    ----------
    base, final : CrossValidation
        The classical and the final model, left-one-configuration-out.
    gain : Comparison
        The final model against the classical one on held-out configurations.
    before, after : dict
        Held-out residual statistics of the classical and the final model (mm).
    test_pose : dict
        The cell's test pose predicted by both models.
    residuals : pandas.DataFrame
        One row per equation: covariates, held-out standardised residuals and LOO-PIT of both models.
    tied_with, contested_by : dict
        Per named cause, the candidates it does not beat on held-out configurations by :data:`DETECTION_Z` SE
        whose fitted deflections differ from its own by a χ² in noise sd below :data:`SEPARABLE_CHI2` (tied), or above
        it (contested).
    explains : dict
        Per named cause, the rivals that would have contested it and that it explains
        (:func:`~bayescal.critique.rule.explains`), each with two comparisons: the rival added on top of the cause,
        and the cause added on top of the rival (a pair of :class:`Comparison`).
    shared_by_state : dict
        The robust candidates that passed but were not named because the markers of a state share their heavy
        tail (the arm's misfit, not gross tracker errors): each with the held-out comparison of the tail per
        state against the tail per reading (:class:`Comparison`, positive).
    by_repeats : dict
        The cause named because it accounts for a misfit the repeats reveal that no candidate passed the rule for
        (:func:`~bayescal.critique.rule.accounts_for`): its lack of fit without it and with it (a pair of
        :class:`~bayescal.inference.lack_of_fit.LackOfFit`).
    importance : dict
        Per named extension, what it changes (:meth:`~bayescal.critique.model.Critique._importance`): residual rms before and after (mm),
        the misfit it explains (mm), the test pose's prediction moved (mm) beside its sd (mm), and whether it matters.
    drift : dict
        Whether the campaign's readings can show a drift and what the rate and walk fitted to them give (:mod:`bayescal.critique.drift`),
        or the drift measured and removed (:meth:`~bayescal.registration.nest_drift.NestDrift.to_json`).
    """

    base: CrossValidation
    final: CrossValidation
    gain: Comparison
    before: dict
    after: dict
    test_pose: dict
    n_configs: int
    n_equations: int
    residuals: pd.DataFrame
    source: str = ""
    lack_of_fit: LackOfFit | None = None
    tied_with: dict = field(default_factory=dict)
    contested_by: dict = field(default_factory=dict)
    explains: dict = field(default_factory=dict)
    shared_by_state: dict = field(default_factory=dict)
    by_repeats: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    importance: dict = field(default_factory=dict)
    drift: dict = field(default_factory=dict)
    rule: dict = field(default_factory=lambda: {"z": DETECTION_Z, "floor_nats": DETECTION_FLOOR, "decisive_nats": DECISIVE_GAIN, "decisive_z": DECISIVE_Z})

    @property
    def negligible(self) -> list[str]:
        """Named causes detectable on held-out configurations but too small to matter (:meth:`~bayescal.critique.model.Critique._importance`)."""
        return [name for name, entry in self.importance.items() if not entry["matters"]]

    @property
    def evidence(self) -> dict[str, Comparison]:
        """Each catalogue extension's comparison at the step it was named, or at the last step for the others."""
        out: dict[str, Comparison] = {}
        for step in self.steps:
            for name, comparison in step.items():
                out[name] = comparison
        return out

    def to_json(self) -> dict:
        evidence = {}
        for step_number, step in enumerate(self.steps, start=1):
            for name, c in step.items():
                evidence[name] = c.to_json() | {"step": step_number, "named": name in self.causes}
        payload = {
            "verdict": self.verdict,
            "causes": list(self.causes),
            "evidence": evidence,
            "gain": self.gain.to_json()
            | {
                "held_out": "leave-one-configuration-out",
                "before": self.before,
                "after": self.after,
                "test_pose": self.test_pose,
            },
            "covariates": {name: c.to_json() | {"meaning": COVARIATES[name]} for name, c in self.probes.items()},
            "rule": {"delta_elpd_over_se": DETECTION_Z, "floor_nats": DETECTION_FLOOR, "decisive_nats": DECISIVE_GAIN,
                     "decisive_over_se": DECISIVE_Z, "by_repeats_over_se": DECISIVE_Z, "tie_below_chi2": SEPARABLE_CHI2},
            "n_configurations": self.n_configs,
            "n_equations": self.n_equations,
            "campaign": self.source,
        }
        if self.unexplained_covariate is not None:
            payload["unexplained_covariate"] = self.unexplained_covariate
        payload["tied_with"] = {cause: list(others) for cause, others in self.tied_with.items()}
        payload["contested_by"] = {cause: list(others) for cause, others in self.contested_by.items()}
        if self.explains:
            # only where a rival was explained, so that a campaign without a contest writes the file it wrote before
            payload["explains"] = {cause: {rival: {"rival_added": rival_added.to_json(), "cause_added": cause_added.to_json()}
                                           for rival, (rival_added, cause_added) in others.items()}
                                   for cause, others in self.explains.items()}
        if self.shared_by_state:
            # only where it happened, so that a campaign without it writes the file it wrote before
            payload["shared_by_state"] = {name: comparison.to_json() | {"meaning": SHARED_BY_STATE} for name, comparison in self.shared_by_state.items()}
        if self.by_repeats:
            # only where it happened, so that a campaign without it writes the file it wrote before
            payload["by_repeats"] = {name: {"lack_of_fit": without.to_json(), "lack_of_fit_with_it": with_it.to_json(), "meaning": BY_REPEATS}
                                     for name, (without, with_it) in self.by_repeats.items()}
        payload["settings"] = dict(self.settings)
        payload["importance"] = {name: dict(entry) for name, entry in self.importance.items()}
        payload["negligible"] = self.negligible
        payload["drift"] = dict(self.drift)
        payload["lack_of_fit"] = None if self.lack_of_fit is None else self.lack_of_fit.to_json() | {
            "model": "final",
            "level": LACK_OF_FIT_LEVEL,
            "meaning": "scatter of the configuration means about the final model against the scatter between repeats",
        }
        return payload

    def document(self, figures: Sequence[str] = ()) -> Summary:
        """What the critique found as one document (:mod:`bayescal.summary`): the text ``bayescal critique`` prints,
        and its Markdown, HTML and JSON; ``figures`` names the files the figures were written to."""
        from bayescal.critique.document import critique_document

        return critique_document(self, figures)

    def diagnostics(self) -> dict:
        """What the comparison rests on: held-out configurations and equations, the decision rule, the
        held-out residual rms (mm) of the classical and the final model, and the repeats' lack-of-fit p-value."""
        return {
            "n_configurations": self.n_configs,
            "n_equations": self.n_equations,
            "rule": dict(self.rule),
            "held_out_rms_mm": {"classical": self.before.get("residual_rms_mm"), "final": self.after.get("residual_rms_mm")},
            "lack_of_fit_p": None if self.lack_of_fit is None else self.lack_of_fit.p_value,
        }

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`to_json` to ``path``."""
        Path(path).write_text(json.dumps(self.to_json(), indent=2, allow_nan=False) + "\n")


@dataclass(frozen=True)
class CritiqueFindings(JsonFindings):
    """What a critique's JSON file (:meth:`CritiqueResults.to_json`, or the geometry critique's) holds.

    Attributes
    ----------
    verdict : str
        One of :data:`VERDICTS`.
    causes : list
        The causes named, in the order added (str each, in a file this version writes).
    evidence : dict
        Candidate -> its held-out comparison at the step it was named, or at the last step: ``delta_elpd`` and
        ``se`` (nats), ``n_configs``, ``step``, ``named``.
    gain : dict
        The final model against the classical one: ``delta_elpd``, ``se`` (nats); ``before``, ``after`` (held-out
        residual statistics, mm); ``test_pose`` (``classical_error_mm``, mm) for a campaign's critique.
    covariates, rule, lack_of_fit : dict or None
        Each covariate probe's comparison (nats) with its meaning; the naming rule (SE multiples and nats); the
        lack-of-fit test against the repeats (``factor``, ``statistic``, ``dof``, ``p_value``, ``level``).
    negligible : list or None
        Named causes detectable but too small to matter.
    keys : tuple of str
        The file's keys in its order (a key held as null apart from one missing).
    extra : dict
        The file's other keys, as they came.
    """

    verdict: str
    causes: list
    evidence: dict
    gain: dict
    covariates: dict | None = None
    rule: dict | None = None
    lack_of_fit: dict | None = None
    negligible: list | None = None
    keys: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)

    SCHEMA = CRITIQUE_JSON
    OPTION = "--critique"
    NAME = "the critique's JSON"
