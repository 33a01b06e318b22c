"""The critiques' naming rule: when a held-out gain names a cause, and when two candidates tie.

A candidate is named when its held-out ΔELPD clears :data:`DETECTION_Z` standard errors and
:data:`DETECTION_FLOOR` nats, or :data:`DECISIVE_GAIN` nats and :data:`DECISIVE_Z` standard errors
(:func:`passes`); :class:`~bayescal.critique.model.Critique` and
:class:`~bayescal.critique.geometry.GeometryCritique` both apply it.  The same rule, applied to each of two
candidates added on top of the other, decides whether the named one explains a rival that contests it
(:func:`explains`).  Where the repeats reveal a misfit that no candidate passes the rule for, a candidate clear of
:data:`DECISIVE_Z` standard errors and :data:`DETECTION_FLOOR` nats that leaves the repeats fitted accounts for it
(:func:`accounts_for`).  Two candidates tie where the plan could not tell them apart by the rule (:func:`separable`).
"""

from __future__ import annotations

import numpy as np

from bayescal.critique.compare import Comparison
from bayescal.inference.lack_of_fit import LackOfFit

__all__ = ["DETECTION_Z", "DETECTION_FLOOR", "DECISIVE_GAIN", "DECISIVE_Z", "SEPARABLE_CHI2", "UNEXPLAINED", "passes", "strongest", "explains",
           "accounts_for", "shows", "separable", "check_candidates"]

DETECTION_Z = 2.0
"""A cause is named only when its held-out gain exceeds this many standard errors of the difference."""
DETECTION_FLOOR = 4.0
"""... and this many nats: below it a gain is within what chance fits of a few extra
parameters give on null campaigns (measured: docs/critique.md)."""
DECISIVE_GAIN = 25.0
"""A held-out gain (nats) named whatever its standard error: the normal approximation of the
SE fails when the gain sits in a few configurations (gross tracker errors hit a few
readings; Sivula et al. 2020), and null campaigns never come near it (docs/critique.md)."""
DECISIVE_Z = 1.0
"""... but not within one standard error of it: a gain of 35.1 ± 42.5 nats named ``outliers`` on an
independent-generator campaign with nothing planted.  One SE, not two, because the SE of a gain that
sits in a few configurations is itself inflated by them (gross tracker errors: 52-384 nats against
SEs of 47-253 on the twin), and the decisive branch exists for those."""
SEPARABLE_CHI2 = max((2 * DETECTION_Z) ** 2, 2 * DETECTION_FLOOR)
"""Two candidates tie only where their fitted predictions of the campaign's deflections differ by a χ² below this
(16), summed over the equations in each equation's noise sd (:func:`separable`).  Were one of them true, the
log-likelihood ratio of this plan's readings for it against the other would have mean χ²/2 and sd √χ²: below
this bound that mean does not clear both :data:`DETECTION_Z` sds and :data:`DETECTION_FLOOR` nats, and this plan's
readings would not, on average, name one over the other by the naming rule.  Above it the plan separates them, and a candidate
the named one does not beat held out is reported as contesting it (``contested_by``), not as tied."""
UNEXPLAINED = "unexplained"


def separable(difference: np.ndarray) -> bool:
    """Whether this plan's readings could tell two fitted candidates apart by the naming rule: the difference of their
    predictions (n,), in each equation's noise sd, has a χ² above :data:`SEPARABLE_CHI2`.  Eight equations a noise sd
    apart do not; one equation five sd apart, or a hundred half an sd apart, do."""
    return float(np.sum(np.square(difference))) > SEPARABLE_CHI2


def check_candidates(names: tuple[str, ...], known) -> None:
    """Refuse candidate names that are not among ``known``."""
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ValueError(f"unknown candidate(s) {', '.join(unknown)}; expected some of {', '.join(known)}")


def strongest(evidence: dict[str, Comparison], decisive: bool = True) -> str | None:
    """The candidate of largest held-out gain among those that pass :func:`passes`, or None."""
    passing = [name for name, c in evidence.items() if passes(c, decisive)]
    return max(passing, key=lambda name: evidence[name].delta_elpd) if passing else None


def passes(comparison: Comparison, decisive: bool = True) -> bool:
    """The naming rule; ``decisive=False`` for the probes, whose many free offsets can fit a few odd configurations."""
    clear = comparison.delta_elpd > max(DETECTION_Z * comparison.se, DETECTION_FLOOR)
    return clear or (decisive and comparison.delta_elpd > max(DECISIVE_GAIN, DECISIVE_Z * comparison.se))


def explains(rival_added: Comparison, named_added: Comparison) -> bool:
    """Whether the named candidate encompasses a rival that contests it (Mizon & Richard 1986): the rival added on top
    of the named one (``rival_added``) does not pass :func:`passes`, while the named one added on top of the rival
    (``named_added``) still does.

    Then what the rival took up of the misfit is part of what the named candidate explains, and the rival is no
    contest.  Both comparisons pass: each explains something the other misses, and the contest stands.  Neither
    passes: the two are substitutes on this campaign, and the contest stands too.
    """
    return not passes(rival_added) and passes(named_added)


def accounts_for(comparison: Comparison, misfit_with: LackOfFit | None) -> bool:
    """Whether a candidate that does not pass :func:`passes` accounts for a misfit the repeats reveal: its held-out gain
    (``comparison``) clears :data:`DECISIVE_Z` standard errors and :data:`DETECTION_FLOOR` nats, and with it the
    repeats are fitted (``misfit_with``, the lack of fit of the model with the candidate, is not significant).

    Two tests, each of its own kind: the repeats' pure error says that the model misses something, of any shape; the
    held-out gain says which shape.  Neither alone names a cause at this gain: the held-out comparison alone needs
    :data:`DETECTION_Z` SE; the repeats alone say only ``unexplained``.  No gain within its own SE is named.
    """
    return shows(comparison) and misfit_with is not None and not misfit_with.significant()


def shows(comparison: Comparison) -> bool:
    """Whether a held-out gain is clear of :data:`DECISIVE_Z` standard errors and :data:`DETECTION_FLOOR` nats: the bar a
    candidate must clear to account for the repeats' misfit (:func:`accounts_for`), and which a drift the campaign's
    repeated readings show must not clear for a physical candidate to be named so."""
    return comparison.delta_elpd > max(DECISIVE_Z * comparison.se, DETECTION_FLOOR)
