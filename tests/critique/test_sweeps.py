"""The sweep critique (bayescal.critique.sweeps), measured on sweeps it was not built from.

The rule was set on the digital twin's clean sweeps (bayescal.twin.sweeps); the effects are planted by the
independent generator (bayescal.twin.independent.sweeps), in forms of its own and with its own noise.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from bayescal.critique.sweeps import CANDIDATES, critique_sweeps
from bayescal_studies.studies.sweep_critique import FOUND_AS, HOME_DEG, _as_sweeps, false_alarms, found, sweep_critique_study
from bayescal.twin.independent.sweeps import SweepEffect, independent_sweeps
from bayescal.twin.sweeps import random_placement

DETECTION_MAGNITUDE = {"gear_ratio": 1.0, "transmission": 3.0, "wobble": 3.0, "range_offset": 300.0}
"""Multiples of each effect's default size at which it is stated to be found (docs/registration.md)."""


def _critique(cell, effect, magnitude, seed, joint=1):
    """The critique of one joint's sweep alone (0-based ``joint``; the fast tests' time), from the independent generator."""
    rng = np.random.default_rng(seed)
    placement = random_placement(rng)
    planted = SweepEffect.draw(effect, magnitude, rng) if effect else None
    table = independent_sweeps(cell, placement, rng, home_deg=HOME_DEG, effect=planted, joints=(joint,))
    return critique_sweeps(_as_sweeps(table), replace(cell.tracker, position=np.zeros(3)))


def test_clean_independent_sweeps_are_adequate(cell, tmp_path):
    result = _critique(cell, None, 1.0, seed=4)
    assert result.verdict == "adequate"
    assert set(result.summary().index.get_level_values("candidate")) == set(CANDIDATES)
    assert "not_a_candidate" in result.to_json()
    assert result.diagnostics()["verdict"] == "adequate"
    result.save(tmp_path / "critique.json")
    assert json.loads((tmp_path / "critique.json").read_text()) == json.loads(json.dumps(result.to_json()))


@pytest.mark.parametrize(("effect", "joint"), [("gear_ratio", 1), ("transmission", 1), ("wobble", 0)])
def test_a_planted_effect_is_named_first_with_its_gain(cell, effect, joint):
    result = _critique(cell, effect, 2 * DETECTION_MAGNITUDE[effect], seed=4, joint=joint)
    assert result.verdict == "misfit"
    first = {c.causes[0] for c in result.joints.values() if c.causes}
    assert FOUND_AS[effect] in first
    row = next(c.evidence.loc[FOUND_AS[effect]] for c in result.joints.values() if c.causes and c.causes[0] == FOUND_AS[effect])
    assert row["rms_candidate_mm"] < row["rms_circle_mm"] and row["delta_elpd"] > 2 * row["se"]


@pytest.mark.slow
def test_no_false_alarm_in_95_percent_of_clean_independent_sweeps(cell):
    table = sweep_critique_study(cell, 100, generator="independent")
    assert false_alarms(table) <= 0.05


@pytest.mark.slow
@pytest.mark.parametrize("effect", list(DETECTION_MAGNITUDE))
def test_each_planted_effect_is_found_at_its_stated_magnitude(cell, effect):
    table = sweep_critique_study(cell, 20, generator="independent", effect=effect, magnitude=DETECTION_MAGNITUDE[effect], seed=8)
    assert found(table, effect)["either_joint"] >= 0.8
