"""Model criticism: where a model disagrees with the measurements, the likely cause, and the gain of fixing it.

:class:`Critique` criticises the classical VJM model on a campaign; :class:`GeometryCritique` the planar
compensator-geometry model on tracker arcs (Table I); :func:`~bayescal.critique.sweeps.critique_sweeps` the
registration's circle model of each joint sweep.

The names below are imported on first use, as ``bayescal``'s own: a reader of a critique's file
(``bayescal report``) needs :mod:`bayescal.critique.results` alone, without the geometry critique's
SciPy optimiser and the registration the campaign's critique loads.
"""

from importlib import import_module

_NAMES = {
    "Critique": "model",
    "CritiqueResults": "results",
    "GeometryCritique": "geometry",
    "GeometryCritiqueResults": "geometry",
}

__all__ = list(_NAMES)


def __getattr__(name: str):
    if name in _NAMES:
        return getattr(import_module(f".{_NAMES[name]}", __name__), name)
    raise AttributeError(f"module 'bayescal.critique' has no attribute '{name}'")
