"""An elastostatic calibration integrated over an uncertain correction of its readings.

When the readings carry a correction known only up to its posterior (the tracker's drift,
:meth:`~bayescal.registration.nest_drift.NestDrift.removed_draws`), the compliances' posterior is
the correction's posterior average of the posteriors given each correction.  :func:`fit_integrated`
estimates it with a few draws of the correction: the campaign corrected by each draw is calibrated
on its own, and the fits' posterior draws are pooled, each fit's chains kept as chains
(:func:`~bayescal.sampling.summary.pooled_tree`).  The correction's error, shared by rows read
together and correlated from row to row, then lies in the spread between the fits, which no
variance added to each row's noise can carry.

Why draws and not the Gaussian integral: given the correction the deflections are linear in
the compliances, but not in the compensator's spring, the link-mass scale and the geometry, and
the noise levels are unknown and sampled; the correction's covariance across rows would have to
join a noise covariance that changes with every noise-level proposal (a dense factorisation of
3N equations each time), where the collapsed sampler now relies on a diagonal one.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from bayescal.cell.campaign import Campaign
from bayescal.errors import InputError
from bayescal.inference.fit_checks import warn_fit_checks
from bayescal.inference.results import ElastostaticResults
from bayescal.sampling.summary import pooled_tree

__all__ = ["fit_integrated"]


def fit_integrated(model, campaign: Campaign, corrected: Sequence[Campaign], rng: np.random.Generator) -> ElastostaticResults:
    """The calibration of ``campaign`` integrated over the corrections of which ``corrected`` are draws.

    Parameters
    ----------
    model : ElastostaticModel
        The model each corrected campaign is fitted with.
    campaign : Campaign
        The campaign corrected by the correction's posterior mean, its uncertainty added to each row's variance: the
        pooled draws are restored on it (:meth:`~bayescal.inference.elastostatic.ElastostaticModel.restore`), so that its
        closed forms, residuals, chi-square and lack of fit are those a saved posterior restored on it gives.
    corrected : sequence of Campaign
        The campaign corrected by each draw of the correction (at least two), no variance added.
    rng : numpy.random.Generator
        Seeds every fit, one after another.

    Returns
    -------
    ElastostaticResults
        The pooled posterior: R-hat the worst of any fit's, ESS their sum, the attributes the first fit's but the
        parameters not identifiable in any fit and every sampler that ran.  The first fit's announcements (what the
        campaign cannot identify) are warned once; the later fits' (the same campaign's) are not; the checks of the fit
        (convergence, chi-square, lack of fit, parameters the data did not determine) are the pooled posterior's.
    """
    if len(corrected) < 2:
        raise ValueError(f"expected at least two corrected campaigns, got {len(corrected)}")
    fits = [model.fit(corrected[0], rng, checks=False)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits += [model.fit(draw, rng, checks=False) for draw in corrected[1:]]
    _check_alike(fits, campaign.source)
    tree = pooled_tree([fit.tree for fit in fits])
    not_identifiable = set().union(*(filter(None, str(fit.tree.attrs["not_identifiable"]).split(",")) for fit in fits))
    tree.attrs["not_identifiable"] = ",".join(sorted(not_identifiable))
    tree.attrs["sampler"] = ", ".join(dict.fromkeys(str(fit.tree.attrs["sampler"]) for fit in fits))
    results = model.restore(campaign, tree)
    warn_fit_checks(results, campaign.source)
    return results


def _check_alike(fits: Sequence[ElastostaticResults], source: str) -> None:
    """Refuse fits whose posteriors hold different parameters: a correction's draws that change what the campaign
    identifies (a column at the edge of being resolved) leave no one posterior to pool."""
    names = [set(map(str, fit.summary().index)) for fit in fits]
    for k, other in enumerate(names[1:], start=1):
        if other != names[0]:
            apart = sorted(names[0] ^ other)
            raise InputError(
                f"what the campaign identifies changes with the correction's draw (draw 1 against draw {k + 1}: "
                f"{', '.join(apart)}): its uncertainty is too large for these parameters; measure it more closely "
                "(reference nests read more often)",
                source=source,
            )
