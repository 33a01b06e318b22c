"""Tracker registration from joint sweeps: the robot's joint axes in the tracker frame."""

from bayescal.registration.axes import AxisFit, fit_axis
from bayescal.registration.sweeps import Sweeps, read_sweeps

__all__ = ["AxisFit", "Sweeps", "fit_axis", "read_sweeps"]
