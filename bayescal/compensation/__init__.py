"""Compliance error compensation of machining programs: corrected joint targets and the error they leave."""

from bayescal.compensation.calibration import Calibration, load_calibration
from bayescal.compensation.compensate import compensate_poses, compensate_program, predicted_errors
from bayescal.compensation.program import Program, read_program
from bayescal.compensation.results import CompensationResults

__all__ = [
    "Calibration",
    "CompensationResults",
    "Program",
    "compensate_poses",
    "compensate_program",
    "load_calibration",
    "predicted_errors",
    "read_program",
]
