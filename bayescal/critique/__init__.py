"""Model criticism: where a model disagrees with the measurements, the likely cause, and the gain of fixing it.

:class:`Critique` criticises the classical VJM model on a campaign; :class:`GeometryCritique` the planar
compensator-geometry model on tracker arcs (Table I); :func:`~bayescal.critique.sweeps.critique_sweeps` the
registration's circle model of each joint sweep.
"""

from bayescal.critique.geometry import GeometryCritique, GeometryCritiqueResults
from bayescal.critique.model import Critique
from bayescal.critique.results import CritiqueResults

__all__ = ["Critique", "CritiqueResults", "GeometryCritique", "GeometryCritiqueResults"]
