"""Tracker registration from joint sweeps: the robot's joint axes and frames in the tracker frame."""

from bayescal.registration.axes import AxisFit, fit_axis
from bayescal.registration.frames import Frame
from bayescal.registration.register import Registration, read_frame, register
from bayescal.registration.sweeps import Sweeps, read_sweeps

__all__ = ["AxisFit", "Frame", "Registration", "Sweeps", "fit_axis", "read_frame", "read_sweeps", "register"]
