"""The plausible loads of a cell: one rule per kind of value, shared by the cell file and the command line.

A load is plausible when it is heavy enough to deflect the arm beyond the tracker's
noise and light enough for the arm to hold.  Both bounds scale with the cell's
capacity: the larger of the robot's rated payload (``robot.payload_kg``) and its
calibration load (``load.mass_kg``).  Each rule returns why a value is implausible,
or ``None``; the caller says where the value came from (the cell file's line and key,
:func:`bayescal.cell.config.load_cell`; or the option, e.g. ``bayescal plan --mass-kg``),
so that the file and the command line apply the same rule.
"""

from __future__ import annotations

import math

from bayescal.cell.loading import MAX_LOAD_ARM

__all__ = ["MIN_LOAD_FRACTION", "OVERLOAD_FACTOR", "couple_limit_violation", "force_limit_violation", "mass_range_violation"]

OVERLOAD_FACTOR = 2.0
"""Largest plausible static load on the arm, as a multiple of the weight of its capacity.

The capacity is the larger of the rated payload (``robot.payload_kg``; the KR-270's
is 270 kg) and the cell's calibration load (``load.mass_kg``): Klimchik et al. hung
250-280 kg on the KR-270, 1.04 times its rating.  Twice the capacity leaves room for
a heavier calibration load or a tool's own weight, while a wrench written in a wrong
unit (N·mm or mN as N·m or N: a factor 1000) lies far beyond it.
"""

MIN_LOAD_FRACTION = 0.01
"""Smallest plausible largest load force of a campaign, as a fraction of the capacity's weight.

``bayescal simulate`` on the Table III plan (250-280 kg) deflects the markers by at
most 9.1 mm, with tracker noise of 32-44 μm per coordinate; 1 % of such a load
moves them by at most about 90 μm, two or three times the noise: not a calibration
load.  A campaign whose largest force is below it is far more likely a wrench
written in kN (1000 times smaller) than one measured so.
"""


def mass_range_violation(low: float, high: float, capacity_kg: float | None = None) -> str | None:
    """Why the masses ``low`` to ``high`` (kg) cannot be a campaign's loads, or ``None``.

    Parameters
    ----------
    low, high
        The lightest and the heaviest mass, kg.
    capacity_kg
        The cell's capacity, kg (:attr:`~bayescal.cell.config.Cell.capacity_weight` over its gravity);
        ``None`` checks the range alone.
    """
    if not (math.isfinite(low) and math.isfinite(high)):
        return f"expected finite masses in kg, got {low:g} to {high:g}"
    if low <= 0:
        return f"expected masses above 0 kg, got {low:g} kg: a load of no mass deflects nothing"
    if low > high:
        return f"expected the lighter mass first, got {low:g} kg then {high:g} kg: the range is reversed"
    if capacity_kg is None:
        return None
    heaviest, lightest = OVERLOAD_FACTOR * capacity_kg, MIN_LOAD_FRACTION * capacity_kg
    if high > heaviest:
        return (
            f"a load of {high:g} kg is more than the {heaviest:.0f} kg the arm can plausibly carry "
            f"({OVERLOAD_FACTOR:g} x its capacity of {capacity_kg:g} kg)" + _unit_hint(high / 1000, lightest, heaviest, "g instead of kg")
        )
    if high < lightest:
        return (
            f"a heaviest load of {high:g} kg is below {lightest:.3g} kg ({MIN_LOAD_FRACTION:.0%} of the arm's capacity of "
            f"{capacity_kg:g} kg), too light to deflect the arm beyond the tracker's noise"
            + _unit_hint(high * 1000, lightest, heaviest, "tonnes instead of kg")
        )
    return None


def force_limit_violation(force: float, capacity_kg: float, gravity: float) -> str | None:
    """Why an end-effector whose largest force is ``force`` (N) cannot calibrate the arm, or ``None``.

    Parameters
    ----------
    force
        The largest force the end-effector applies, N (``[load] force_max_N``, eq 41's ``F_max``).
    capacity_kg
        The cell's capacity, kg (:attr:`~bayescal.cell.config.Cell.capacity_weight` over its gravity).
    gravity
        The cell's gravitational acceleration, m/s².
    """
    if not math.isfinite(force) or force <= 0:
        return f"expected a force above 0 N, got {force:g}"
    heaviest, lightest = OVERLOAD_FACTOR * capacity_kg * gravity, MIN_LOAD_FRACTION * capacity_kg * gravity
    if force > heaviest:
        return (
            f"a force of {force:g} N is more than the {heaviest:.0f} N the arm can plausibly hold "
            f"({OVERLOAD_FACTOR:g} x the weight of its capacity of {capacity_kg:g} kg)" + _unit_hint(force / 1000, lightest, heaviest, "mN instead of N")
        )
    if force < lightest:
        return (
            f"a largest force of {force:g} N is below {lightest:.0f} N ({MIN_LOAD_FRACTION:.0%} of the weight of the arm's "
            f"capacity of {capacity_kg:g} kg), too small to deflect the arm beyond the tracker's noise"
            + _unit_hint(force * 1000, lightest, heaviest, "kN instead of N")
        )
    return None


def couple_limit_violation(couple: float, force: float, capacity_kg: float, gravity: float) -> str | None:
    """Why an end-effector whose largest couple is ``couple`` (N·m) is implausible, or ``None``.

    A couple needs a force acting at most :data:`~bayescal.cell.loading.MAX_LOAD_ARM`
    from the flange, the larger of the end-effector's ``force`` (N) and the weight of
    the capacity (``capacity_kg`` kg under ``gravity`` m/s²): the bound the campaigns' moments are held to.
    """
    if not math.isfinite(couple) or couple < 0:
        return f"expected a couple of 0 N·m or more, got {couple:g}"
    lever = max(force, capacity_kg * gravity)
    if couple > lever * MAX_LOAD_ARM:
        return (
            f"a couple of {couple:g} N·m needs a force of {lever:.0f} N to act {couple / lever:.3g} m from the flange, "
            f"beyond any tool ({MAX_LOAD_ARM:g} m)" + _unit_hint(couple / 1000, 0.0, lever * MAX_LOAD_ARM, "N·mm instead of N·m")
        )
    return None


def _unit_hint(rescaled: float, low: float, high: float, units: str) -> str:
    """``": is it in <units>?"`` when the value read in those units, ``rescaled``, is plausible; else nothing."""
    return f": is it in {units}?" if low <= rescaled <= high else ""
