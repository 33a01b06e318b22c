"""The registry of compensator laws: the cell's ``[compensator] kind`` names one of :data:`LAWS`."""

from __future__ import annotations

from bayescal.robot.compensator import Compensator
from bayescal.robot.hydro import HydroCompensator

__all__ = ["DEFAULT_KIND", "LAWS"]

LAWS = {law.kind: law for law in (Compensator, HydroCompensator)}
"""``{kind: law class}``: each a :class:`~bayescal.robot.laws.CompensatorLaw`."""
DEFAULT_KIND = Compensator.kind
"""The kind of a ``[compensator]`` table without ``kind``: the spring of eqs 4-9, as on the KR-270."""
