"""Model criticism: where the classical VJM model disagrees with a campaign, the likely cause, and the gain of fixing it."""

from bayescal.critique.model import Critique, CritiqueResults

__all__ = ["Critique", "CritiqueResults"]
