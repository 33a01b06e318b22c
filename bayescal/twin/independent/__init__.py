"""An independent generator of calibration campaigns with planted effects.

Written apart from the package's identification, its digital twin and its model
criticism, so that they can be checked on data they were not built from: its own
static equilibrium (``solver``), mechanical effects (``structure``), tracker noise
and readout errors (``noise``), the effects' registry (``effects``), random plans
(``plans``) and the generator itself (``generator``).
"""

from bayescal.twin.independent.effects import CAUSES, EFFECTS, PlantedEffect, World
from bayescal.twin.independent.generator import SPREADS, TIMELINE, IndependentGenerator, Truth
from bayescal.twin.independent.plans import random_plan

__all__ = ["CAUSES", "EFFECTS", "PlantedEffect", "World", "IndependentGenerator", "Truth", "SPREADS", "TIMELINE", "random_plan"]
