"""What a plantable effect is, in each of the package's simulators: one idiom, each simulator's physics its own.

An effect is a frozen dataclass whose instance is the effect at one ``magnitude`` (in its ``unit``); its class
names it and gives its unit, its documented ``default`` magnitude and a one-line ``summary``.  A simulator's
effects are subclasses of :class:`Planted` that add where they act (the digital twin's
:class:`bayescal.twin.effects.Effect`, the independent generator's
:class:`bayescal.twin.independent.effects.PlantedEffect`), and its registry maps each name to its class.  This
module holds no physics, so that the independent generator shares the idiom and nothing of the twin's models.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Planted"]


@dataclass(frozen=True)
class Planted:
    """An effect at ``magnitude``, in the class's :attr:`unit` (finite, >= 0)."""

    magnitude: float

    name = ""
    unit = ""
    default = 0.0
    summary = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.magnitude) and self.magnitude >= 0):
            raise ValueError(f"effect '{self.name}' needs a finite magnitude >= 0 in {self.unit}, got {self.magnitude:g}")

    def describe(self) -> str:
        """``name=magnitude unit``."""
        return f"{self.name}={self.magnitude:g} {self.unit}"
