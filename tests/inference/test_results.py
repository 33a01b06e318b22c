"""Tests of bayescal.inference.results: one results shape, the same numbers through every verb."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.sampling.gibbs import GibbsSampler


@pytest.fixture(scope="module")
def results(cell, campaign_csv):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=2, n_tune=100, n_draws=150))
        return model.fit(read_campaign(campaign_csv, cell=cell), 0)


def test_summary_is_a_copy_and_the_results_do_not_change_when_it_is_edited(results):
    first = results.summary()
    first.loc[first.index[0], "mean"] = 1e9
    assert results.summary().loc[first.index[0], "mean"] != 1e9


def test_to_json_is_strict_json_and_carries_every_verb(results):
    payload = results.to_json()
    text = json.dumps(payload, allow_nan=False)
    assert set(payload) >= {"parameters", "weakly_determined", "k2_per_angle", "diagnostics", "identifiability"}
    assert json.loads(text) == payload
    assert set(payload["parameters"]) == set(results.parameters())
    summary = results.summary()
    for name, entry in payload["parameters"].items():
        if "mean" in entry:
            assert entry["mean"] == pytest.approx(summary.loc[name, "mean"])
    assert payload["diagnostics"]["r_hat_max"] == pytest.approx(results.diagnostics()["r_hat_max"])


def test_per_angle_holds_one_entry_per_campaign_angle(results):
    per_angle = results.per_angle()
    assert sorted(per_angle) == pytest.approx(sorted(np.round(np.degrees(results.compensated_angles), 3)))
    for entry in per_angle.values():
        assert ("mean" in entry and entry["lo3"] < entry["mean"] < entry["hi3"]) or entry["identifiable"] is False
