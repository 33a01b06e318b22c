"""Tests for the encompassing of a contest (bayescal/critique/rule.py ``explains``, model.py ``_explained``): a rival
that adds nothing on top of the named cause, while the cause still adds on top of it, is explained, not a contest."""

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from bayescal.critique import Critique
from bayescal.critique.compare import Comparison, compare_elpd
from bayescal.critique.extensions import Extension
from bayescal.critique.model import _greedy_search
from bayescal.critique.results import CritiqueFindings
from bayescal.critique.rule import DETECTION_Z, explains, passes


def test_a_rival_is_explained_only_when_it_adds_nothing_and_the_named_cause_still_does():
    nothing, something = Comparison(1.0, 3.0, 20), Comparison(30.0, 5.0, 20)
    assert not passes(nothing) and passes(something)
    assert explains(nothing, something)
    # the reverse: the rival explains the named cause, which is no reason to drop the contest
    assert not explains(something, nothing)
    # both add to each other, or neither does: the contest stands
    assert not explains(something, something) and not explains(nothing, nothing)


def _search(rival_adds: bool):
    """The greedy search on held-out scores made up per model: ``a`` leads ``b`` by 27 nats at 1.5 SE (a contest:
    their fitted predictions differ by 3 noise sd), ``b``'s gain sits in three configurations ``a`` misses.
    ``rival_adds``: the model with both takes up those three configurations too, else it scores as ``a`` alone."""
    rng = np.random.default_rng(1)
    base = rng.normal(size=20)
    b = base + 10.0 + 0.1 * rng.normal(size=20)
    a = b + np.r_[np.full(17, 3.0), np.full(3, -8.0)]
    both = a + (np.r_[np.zeros(17), np.full(3, 12.0)] if rival_adds else 0.01 * rng.normal(size=20))
    scores = {(): base, ("a",): a, ("b",): b, ("a", "b"): both}

    def validate(model):
        return SimpleNamespace(elpd=scores[tuple(sorted(e.name for e in model.extensions))])

    noise = np.full(60, 1e-5)
    fitted = {"a": np.zeros(60), "b": np.full(60, 3 * 1e-5)}
    candidates = [Extension(name, name, lambda rows, cell: None) for name in "ab"]
    search = _greedy_search(SimpleNamespace(elpd=base), candidates, validate, lambda model, cv: fitted[model.extensions[-1].name],
                            lambda cv: noise)
    return search, compare_elpd(b, a)


def test_a_rival_nested_in_the_named_cause_is_explained_not_a_contest():
    search, lead = _search(rival_adds=False)
    # the premise: a does not beat b by DETECTION_Z SE held out, but passes on top of it by the decisive branch
    assert 25.0 < lead.delta_elpd < DETECTION_Z * lead.se and passes(lead)
    assert search.causes == ["a"]
    assert search.contested["a"] == [] and search.tied["a"] == []
    rival_added, named_added = search.explained["a"]["b"]
    assert not passes(rival_added) and named_added.delta_elpd == pytest.approx(lead.delta_elpd, abs=0.5)


def test_a_rival_that_adds_on_top_of_the_named_cause_still_contests_it():
    search, _ = _search(rival_adds=True)
    assert search.contested["a"] == ["b"] and search.explained["a"] == {}
    # and the search names it next, on top of a
    assert search.causes == ["a", "b"]


@pytest.fixture(scope="module")
def backlash(cell, twin_campaign):
    return Critique(cell).run(twin_campaign(["backlash"], seed=2), np.random.default_rng(0))


def test_the_json_and_the_text_say_which_rival_was_explained_and_only_then(backlash):
    assert "explains" not in backlash.to_json()
    explained = replace(backlash, explains={"backlash": {"outliers": (Comparison(-1.25, 2.5, 30), Comparison(40.0, 30.0, 30))}})
    payload = json.loads(json.dumps(explained.to_json()))
    assert payload["explains"] == {"backlash": {"outliers": {"rival_added": {"delta_elpd": -1.25, "se": 2.5, "n_configs": 30},
                                                             "cause_added": {"delta_elpd": 40.0, "se": 30.0, "n_configs": 30}}}}
    assert CritiqueFindings.from_json(payload).extra["explains"] == payload["explains"]
    assert ("backlash explains outliers: outliers adds -1.2 ± 2.5 nats on top of it, backlash 40.0 ± 30.0 on top of "
            "outliers, so outliers does not contest it" in " ".join(explained.document().as_text().split()))
