"""Kinematic and self-weight elastic calibration from measured marker positions, on any robot tree.

``KinematicCalibration(load_points_cell(cell), rung).fit(read_positions(file, cell))``
returns :class:`KinematicResults`; :class:`ModelLadder` fits every rung and says
what each extension gains on held-out configurations.
"""

from bayescal.kinematics.cell import PointsCell, load_points_cell
from bayescal.kinematics.fit import KinematicCalibration
from bayescal.kinematics.model import EXTENSIONS, GROUPS, RUNGS, PointModel
from bayescal.kinematics.positions import Positions, read_positions
from bayescal.kinematics.results import KinematicResults
from bayescal.kinematics.saved import load_kinematic_calibration

__all__ = ["EXTENSIONS", "GROUPS", "RUNGS", "KinematicCalibration", "KinematicResults", "PointModel", "PointsCell", "Positions",
           "load_kinematic_calibration", "load_points_cell", "read_positions"]
