"""Compliance error compensation of machining programs: corrected joint targets and the error they leave."""

from bayescal.compensation.budget import ErrorBudget, error_budget
from bayescal.compensation.calibration import Calibration, load_calibration
from bayescal.compensation.compensate import compensate_poses, compensate_program
from bayescal.compensation.program import Program, read_program
from bayescal.compensation.results import CompensationResults

__all__ = [
    "Calibration",
    "CompensationResults",
    "ErrorBudget",
    "Program",
    "compensate_poses",
    "compensate_program",
    "error_budget",
    "load_calibration",
    "read_program",
]
