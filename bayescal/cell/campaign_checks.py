"""A campaign's plausibility against its cell: wrenches and deflections.

:func:`~bayescal.cell.campaign.read_campaign` runs these checks when it is given
the cell (its joint angles are checked by :mod:`bayescal.cell.joint_tables`); each
names the line and column of the first row that fails and, when the data point to
one, the unit slip or swap that most likely caused it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from bayescal.cell.config import MIN_LOAD_FRACTION, OVERLOAD_FACTOR, Cell
from bayescal.cell.loading import MAX_LOAD_ARM, WRENCH_COLUMNS
from bayescal.errors import InputError
from bayescal.units import DEG, MM

__all__ = ["check_wrench", "check_deflection", "check_force_columns", "DEFLECTION_Z", "ACROSS_ANGLE", "ALONG_ANGLE"]


def check_wrench(
    cell: Cell, wrench: np.ndarray, lines: Sequence[int], source: str, *, what: str = "load", about: str = "the flange", smallest: bool = True
) -> None:
    """Reject wrenches the arm cannot carry or that no load on a tool produces: a wrench in a wrong unit.

    Parameters
    ----------
    cell
        Gives the scale: :attr:`~bayescal.cell.config.Cell.max_force` and
        :attr:`~bayescal.cell.config.Cell.capacity_weight`.
    wrench
        (M, 6) ``[f (N); m (N·m)]``, one row per configuration.
    lines
        (M,) the line of each row, for the messages.
    source
        The file, for the messages.
    what, about
        The kind of force (a calibration ``load``, a machining ``process`` force) and the point the
        moment is taken about, for the messages.
    smallest
        Also refuse a largest force too small to be a calibration load (a machining program may rest).

    Raises
    ------
    InputError
        A force above ``cell.max_force`` (a wrench 1000 times too large, or 1e12 N),
        a moment that needs its force to act more than :data:`MAX_LOAD_ARM` from
        the flange (moments in N·mm), or a campaign whose largest force is below
        :data:`~bayescal.cell.config.MIN_LOAD_FRACTION` of the capacity's weight
        (a wrench in kN).
    """
    force = np.linalg.norm(wrench[:, :3], axis=1)
    capacity = cell.capacity_weight / cell.gravity
    worst = int(np.argmax(force))
    if force[worst] > cell.max_force:
        column = WRENCH_COLUMNS[int(np.argmax(np.abs(wrench[worst, :3])))]
        raise InputError(
            f"a {what} force of {force[worst]:.4g} N is more than the {cell.max_force:.0f} N the arm can plausibly carry "
            f"({OVERLOAD_FACTOR:g} x the weight of {capacity:g} kg, from {cell.source}): is the wrench in another unit "
            "than N and N·m?",
            source=source,
            line=int(lines[worst]),
            column=column,
        )
    _check_moments(cell, wrench, lines, source, what, about)
    floor = MIN_LOAD_FRACTION * cell.capacity_weight
    if smallest and 0 < force[worst] < floor:
        raise InputError(
            f"the largest load force of the campaign is {force[worst]:.4g} N, below {floor:.0f} N "
            f"({MIN_LOAD_FRACTION:.0%} of the weight of {capacity:g} kg, from {cell.source}), too small to deflect "
            "the arm beyond the tracker's noise: is the wrench in kN instead of N?",
            source=source,
            line=int(lines[worst]),
            column=WRENCH_COLUMNS[int(np.argmax(np.abs(wrench[worst, :3])))],
        )



def _check_moments(cell: Cell, wrench: np.ndarray, lines: Sequence[int], source: str, what: str, about: str) -> None:
    """Refuse a moment whose force would act beyond :data:`MAX_LOAD_ARM` (see :func:`check_wrench`)."""
    force = np.linalg.norm(wrench[:, :3], axis=1)
    moment = np.linalg.norm(wrench[:, 3:], axis=1)
    # A force at the flange gives a moment |m| <= |f| times its arm; a pure moment is bounded by the capacity's.
    arm_limit = np.maximum(force, cell.capacity_weight) * MAX_LOAD_ARM
    beyond = np.flatnonzero(moment > arm_limit)
    if beyond.size:
        row = int(beyond[0])
        column = WRENCH_COLUMNS[3 + int(np.argmax(np.abs(wrench[row, 3:])))]
        raise InputError(
            f"a moment of {moment[row]:.4g} N·m needs the {what} force to act {moment[row] / max(force[row], cell.capacity_weight):.3g} m "
            f"or more from {about}, beyond any tool ({MAX_LOAD_ARM:g} m): are mx_Nm..mz_Nm in N·mm instead of N·m?",
            source=source,
            line=int(lines[row]),
            column=column,
        )


DEFLECTION_Z = 3.0
"""Standard errors by which the markers' mean motion along the load force must be negative for
:func:`check_deflection` to refuse a campaign: on loads lost in the noise it refused 10 of 4,000 random
20-row campaigns (0.25 %), and 0 of 1,000 random elastic campaigns (tests/cell/test_campaign.py's generator)."""


ACROSS_ANGLE = 70 * DEG
ALONG_ANGLE = 60 * DEG
"""Median angles (rad) between the markers' deflections and their load forces: a campaign whose median exceeds
``ACROSS_ANGLE``, and falls below ``ALONG_ANGLE`` once two force columns are exchanged, has those columns
swapped.  Measured on twin campaigns of 3 to 19 random configurations of the KR-270 (half with hanging masses,
half with forces of 500-3,000 N in random directions; each with up to two random effects of the twin): over
2,000 of them the median angle never exceeded 58 deg; over another 2,000, none was refused, and of their 5,000
exchanges of two force columns that move the force, 3,231 were refused, each naming the pair exchanged."""

_FORCE_SWAPS = ((0, 2), (1, 2), (0, 1))
"""The pairs of force columns (fx_N, fy_N, fz_N) that may be exchanged, vertical force first."""

_SWAP_CONFIGURATIONS = 3
"""Fewest loaded configurations on which :data:`ACROSS_ANGLE` and :data:`ALONG_ANGLE` were measured."""


def check_deflection(wrench: np.ndarray, positions: np.ndarray, lines: Sequence[int], source: str) -> None:
    """Reject a campaign whose markers move against its load: unloaded and loaded columns swapped, or the wrench's sign flipped.

    The arm's compliance is positive definite, so a load force does positive
    work: the point it acts on, and with it the tool's markers, moves along the
    force.  A campaign whose markers move on average against the force, by
    more than :data:`DEFLECTION_Z` standard errors of that mean, is refused; so
    is one whose every wrench is zero.  Markers that move across their forces
    rather than against them are :func:`check_force_columns`' to judge.

    Parameters
    ----------
    wrench
        (n, 6) wrench of every row, N and N·m.
    positions
        (n, 6) unloaded then loaded marker positions of every row, m.
    lines
        (n,) the rows' line numbers in ``source``.
    source
        The campaign file, named in the error.

    Raises
    ------
    InputError
        Naming the line of the first row that moves against its load.
    """
    force = np.linalg.norm(wrench[:, :3], axis=1)
    if not np.any(np.abs(wrench) > 0):
        raise InputError(
            "every wrench fx_N..mz_Nm is zero: a campaign without a load deflects nothing; were the wrench columns left empty?",
            source=source,
            line=int(lines[0]),
            column="fz_N",
        )
    loaded = force > 0
    if np.count_nonzero(loaded) < 2:
        return
    along = np.einsum("ij,ij->i", positions[loaded, 3:] - positions[loaded, :3], wrench[loaded, :3] / force[loaded, None])
    mean, error = float(along.mean()), float(along.std(ddof=1) / np.sqrt(along.size))
    if mean < 0 and mean < -DEFLECTION_Z * error:
        first = int(np.flatnonzero(along < 0)[0])
        raise InputError(
            f"the markers move against the load force in {np.count_nonzero(along < 0)} of {along.size} rows "
            f"(on average {-mean / MM:.3g} mm opposite to it), which no elastic arm does: are the unloaded (x0_mm..z0_mm) and "
            "loaded (x1_mm..z1_mm) columns swapped, or the wrench's sign flipped?",
            source=source,
            line=int(lines[loaded][first]),
            column="x1_mm",
        )


def check_force_columns(wrench: np.ndarray, deflection: np.ndarray, lines: Sequence[int], source: str) -> None:
    """Refuse markers that move across their load forces but along them with two force columns exchanged (the pair named).

    Exchanging two force columns and exchanging the same two position axes turn the
    deflections against the forces alike: run it once the markers are known to sit on
    the tool (:func:`bayescal.inference.equations.check_campaign`), which rules out the latter.

    Parameters
    ----------
    wrench
        (n, 6) wrench of every row, N and N·m.
    deflection
        (n, 3) each row's loaded minus unloaded marker position, m.
    lines
        (n,) the rows' line numbers in ``source``.
    source
        The campaign file, named in the error.

    Raises
    ------
    InputError
        When the median angle between deflection and force exceeds :data:`ACROSS_ANGLE` and falls below
        :data:`ALONG_ANGLE` with two force columns exchanged (and below the angle with the force's sign flipped).
    """
    loaded = np.linalg.norm(wrench[:, :3], axis=1) > 0
    force, deflection, lines = wrench[loaded, :3], deflection[loaded], np.asarray(lines)[loaded]
    if np.unique(force, axis=0).shape[0] < _SWAP_CONFIGURATIONS:
        return
    moved = np.linalg.norm(deflection, axis=1) > 0
    if not moved.any():
        return
    force, deflection, lines = force[moved], deflection[moved], lines[moved]

    def median_angle(candidate: np.ndarray) -> float:
        cosine = np.einsum("ij,ij->i", deflection, candidate) / np.linalg.norm(deflection, axis=1) / np.linalg.norm(candidate, axis=1)
        return float(np.median(np.arccos(np.clip(cosine, -1.0, 1.0))))

    stated = median_angle(force)
    if stated <= ACROSS_ANGLE:
        return
    exchanged = {}
    for a, b in _FORCE_SWAPS:
        order = [0, 1, 2]
        order[a], order[b] = b, a
        exchanged[(a, b)] = median_angle(force[:, order])
    (a, b), best = min(exchanged.items(), key=lambda item: item[1])
    # A flipped sign is the other check's to name: exchange columns only when that explains more than a flip.
    if best < ALONG_ANGLE and best < median_angle(-force):
        first, second = WRENCH_COLUMNS[a], WRENCH_COLUMNS[b]
        raise InputError(
            f"the markers move across the load force (median angle {stated / DEG:.0f} deg between deflection and force, "
            f"over {force.shape[0]} rows) but along it with {first} and {second} exchanged ({best / DEG:.0f} deg): "
            f"are the columns {first} and {second} swapped?",
            source=source,
            line=int(lines[0]) or None,
            column=first,
        )
