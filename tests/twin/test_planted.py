"""The twin's and the independent generator's effects are written in one idiom, under names of their own."""

import math

import pytest

from bayescal.twin.effects import EFFECTS as TWIN_EFFECTS
from bayescal.twin.independent import EFFECTS as INDEPENDENT_EFFECTS
from bayescal.twin.planted import Planted


@pytest.mark.parametrize("registry", [TWIN_EFFECTS, INDEPENDENT_EFFECTS], ids=["twin", "independent"])
def test_every_effect_is_a_planted_class_registered_under_its_name(registry):
    for name, effect in registry.items():
        assert issubclass(effect, Planted) and effect.name == name
        assert effect.summary and effect.unit and math.isfinite(effect.default) and effect.default >= 0
        assert effect(effect.default).describe() == f"{name}={effect.default:g} {effect.unit}"


def test_the_two_simulators_effects_share_no_name():
    # the independent generator is measured against the critique, whose candidates are the twin's names
    assert not set(TWIN_EFFECTS) & set(INDEPENDENT_EFFECTS)
    assert not {e.__name__ for e in TWIN_EFFECTS.values()} & {e.__name__ for e in INDEPENDENT_EFFECTS.values()}


def test_a_negative_or_infinite_magnitude_is_refused_by_either():
    for effect in (TWIN_EFFECTS["backlash"], INDEPENDENT_EFFECTS["gear_play"]):
        for bad in (-1.0, math.inf, math.nan):
            with pytest.raises(ValueError, match="needs a finite magnitude >= 0"):
                effect(bad)
