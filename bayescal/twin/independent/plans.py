"""Random campaign plans: a few angles of joint 2, random configurations at each, random loads.

Joint 2's angles are spread evenly over its range (one random angle in each of
``angles`` equal strata); at each, the other joints are drawn uniformly within their
limits (the first turn of a joint that turns more than once) until the
configuration is one a tracker campaign can measure: the tool's axis, along which
the markers face, within the acceptance angle of the line to the tracker, and the
load point above the floor by the hanging clearance.
"""

from __future__ import annotations

import math

import numpy as np

from bayescal.cell.config import Cell
from bayescal.cell.plan import Plan
from bayescal.units import DEG

__all__ = ["random_plan"]

ACCEPTANCE = 60.0 * DEG
"""Largest angle (rad) between the tool axis and the line to the tracker when the cell gives none: ESTIMATE
of a reflector's acceptance cone."""
CLEARANCE = 0.5
"""Height (m) the load point keeps above the floor (z = 0) when the cell gives none: a sling and a 250 kg mass."""
MARGIN = 5.0 * DEG
"""Distance (rad) kept from every joint limit."""
_TRIES = 20000
"""Configurations drawn per plan row before giving up."""


def _measurable(cell: Cell, q: np.ndarray) -> bool:
    rotation, origin = cell.robot.flange_pose(q)
    markers = np.array(list(cell.markers.values()))
    centre = (markers.mean(axis=0)) @ rotation.T + origin
    sight = cell.tracker.position - centre
    acceptance = cell.design.acceptance or ACCEPTANCE
    if rotation[:, 0] @ sight < math.cos(acceptance) * np.linalg.norm(sight):
        return False
    floor = cell.design.floor_z if cell.design.floor_z is not None else 0.0
    clearance = cell.design.hanging_clearance if cell.design.hanging_clearance is not None else CLEARANCE
    return bool((rotation @ cell.load_point + origin)[2] >= floor + clearance)


def random_plan(
    cell: Cell,
    rng: np.random.Generator,
    *,
    angles: int = 6,
    per_angle: int = 5,
    mass_kg: tuple[float, float] = (200.0, 300.0),
) -> Plan:
    """A random plan of ``angles`` joint-2 angles × ``per_angle`` configurations, loads uniform in ``mass_kg``.

    Returns
    -------
    Plan
        ``angles·per_angle`` rows grouped by joint-2 angle, with ``load_kg``.

    Raises
    ------
    ValueError
        When no measurable configuration is found at some angle in :data:`_TRIES` draws.
    """
    lower = np.maximum(cell.robot.lower, -math.pi) + MARGIN
    upper = np.minimum(cell.robot.upper, math.pi) - MARGIN
    edges = np.linspace(lower[1], upper[1], angles + 1)
    rows = []
    for stratum in range(angles):
        q2 = rng.uniform(edges[stratum], edges[stratum + 1])
        for _ in range(per_angle):
            for _ in range(_TRIES):
                q = rng.uniform(lower, upper)
                q[1] = q2
                if _measurable(cell, q):
                    rows.append(q)
                    break
            else:
                raise ValueError(f"no measurable configuration found at q2 = {q2 / DEG:.1f} deg")
    masses = rng.uniform(*mass_kg, size=len(rows))
    return Plan(np.array(rows), masses, np.zeros(len(rows), dtype=int), source="<random plan>")
