"""Tests of bayescal.inference.samplers: the elastostatic posterior's samplers by name."""

from __future__ import annotations

import pytest

from bayescal.inference.samplers import elastostatic_sampler
from bayescal.sampling.collapsed import CollapsedSampler
from bayescal.sampling.ensemble import EnsembleSampler
from bayescal.sampling.gibbs import GibbsSampler


def test_the_samplers_are_sized_alike_by_the_same_number_of_draws():
    assert isinstance(elastostatic_sampler(), CollapsedSampler)
    gibbs, emcee = elastostatic_sampler("gibbs"), elastostatic_sampler("emcee")
    assert isinstance(gibbs, GibbsSampler) and isinstance(emcee, EnsembleSampler)
    assert elastostatic_sampler("gibbs", n_draws=400).n_draws == 400
    # emcee's walker steps are a quarter of the draws asked for, so that --draws means comparable ESS
    assert elastostatic_sampler("emcee", n_draws=400).n_draws == 100
    with pytest.raises(ValueError, match="gibbs"):
        elastostatic_sampler("nuts")


@pytest.mark.parametrize("name", ["collapsed", "gibbs", "emcee"])
def test_every_sampler_takes_chains_and_tuning_steps_by_keyword(name):
    sampler = elastostatic_sampler(name, n_chains=3, n_tune=7)
    assert (sampler.n_chains, sampler.n_tune) == (3, 7)
