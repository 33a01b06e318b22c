"""A calibration integrated over draws of a correction of its readings: the fits pooled, each fit's chains kept."""

import warnings
from dataclasses import replace

import numpy as np
import pytest

from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.inference.mixture import fit_integrated
from bayescal.inference.samplers import elastostatic_sampler
from bayescal.sampling.summary import COMPONENT
from bayescal.twin.simulator import DigitalTwin


@pytest.fixture(scope="module")
def integrated(cell, plan):
    """A Table III campaign (seed 2), two copies whose loaded readings are shifted along z by ±40 μm (a drift's draws
    that disagree), and the calibration integrated over the two, with the warnings it gave."""
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(2))
    shifted = [replace(campaign, p1=campaign.p1 + [0.0, 0.0, dz]) for dz in (-40e-6, 40e-6)]
    model = ElastostaticModel.from_cell(cell, model="linear", sampler=elastostatic_sampler("collapsed", n_chains=8, n_draws=200))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        results = fit_integrated(model, campaign, shifted, np.random.default_rng(3))
    return campaign, shifted, model, results, [str(w.message) for w in caught]


def test_the_pooled_posterior_holds_every_fits_chains_and_spans_their_disagreement(cell, integrated):
    campaign, shifted, model, results, _ = integrated
    posterior = results.tree["posterior"]
    assert posterior.sizes["chain"] == 16 and list(np.unique(posterior[COMPONENT].values)) == [0, 1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        apart = [model.fit(copy, 3).parameters()["k3"] for copy in shifted]
    pooled = results.parameters()["k3"]
    # the mixture's mean between the two fits', its sd at least the larger one's and at least half their distance
    assert min(a["mean"] for a in apart) < pooled["mean"] < max(a["mean"] for a in apart)
    assert pooled["sd"] >= max(0.95 * a["sd"] for a in apart)
    assert pooled["sd"] >= 0.45 * abs(apart[0]["mean"] - apart[1]["mean"])
    # convergence judged within each fit: the fits differ by design
    assert results.diagnostics()["r_hat_max"] < 1.05


def test_the_pooled_posterior_restores_on_the_campaign_it_was_fitted_for(cell, integrated):
    campaign, _, model, results, _ = integrated
    restored = model.restore(campaign, results.tree)
    assert restored.parameters() == results.parameters() and restored.chi2_per_dof == results.chi2_per_dof
    assert restored.summary()["r_hat"].equals(results.summary()["r_hat"])


def test_the_pooled_posteriors_checks_are_warned_once_and_one_copy_is_refused(cell, integrated):
    campaign, shifted, model, _, messages = integrated
    # the spring the campaign cannot determine: checked on the pooled posterior, not on each fit
    assert sum(message.startswith("K_c is not identifiable from these data") for message in messages) == 1
    with pytest.raises(ValueError, match="at least two"):
        fit_integrated(model, campaign, shifted[:1], np.random.default_rng(3))


def test_draws_that_change_what_the_campaign_identifies_are_refused_in_one_line():
    import pandas as pd

    from bayescal.errors import InputError
    from bayescal.inference.mixture import _check_alike

    class Fit:
        def __init__(self, names):
            self.names = names

        def summary(self):
            return pd.DataFrame(index=self.names)

    _check_alike([Fit(["k2", "k3"]), Fit(["k2", "k3"])], "c.csv")
    with pytest.raises(InputError, match=r"draw 1 against draw 3: K_c\)") as error:
        _check_alike([Fit(["k2", "k3"]), Fit(["k2", "k3"]), Fit(["k2", "k3", "K_c"])], "c.csv")
    assert "\n" not in str(error.value) and "c.csv" in str(error.value)
