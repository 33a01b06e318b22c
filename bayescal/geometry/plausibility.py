"""Plausibility of tracker points of compensator markers beyond their format: joint angles in the unit the columns name.

:func:`~bayescal.geometry.arcs.read_arc_points` calls :func:`check_angle_unit` on every file it reads, so that
``bayescal geometry`` and ``bayescal critique --geometry`` refuse the same files.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.errors import InputError
from bayescal.units import DEG, MM

__all__ = ["MAX_ARC_RADIUS", "check_angle_unit"]


MAX_ARC_RADIUS = 2.0
"""Largest radius (m) of a compensator marker's arc about its axis: 11 times the KR-270's lever
(0.183 m on Table I); Table I with q2 written in rad reads as a radius of 10.5 m."""


def check_angle_unit(frame: pd.DataFrame, columns: list[str], source: str) -> None:
    """Reject joint angles that turn the markers too little for how far they move: q2 written in rad.

    A point on a circle of radius r moves by a chord of at most r·Δq when the joint
    turns by Δq, so chord / Δq is a lower bound of its radius; above
    :data:`MAX_ARC_RADIUS` no compensator marker could have moved so.

    Parameters
    ----------
    frame
        The points as read: ``q2_deg``, ``marker`` and the coordinate ``columns`` in mm, indexed by line.
    columns
        The coordinate columns, ``x_mm, y_mm`` and optionally ``z_mm``.
    source
        The file, named in the error.

    Raises
    ------
    InputError
        Naming the line and ``q2_deg`` when a marker's implied radius exceeds :data:`MAX_ARC_RADIUS`.
    """
    worst, where = 0.0, None
    for marker, group in frame.groupby("marker", sort=False):
        q = group["q2_deg"].to_numpy() * DEG
        xyz = group[columns].to_numpy() * MM
        i, j = np.triu_indices(len(q), k=1)
        turn = np.abs(q[i] - q[j])
        usable = turn > 0
        if not usable.any():
            continue
        ratio = np.linalg.norm(xyz[i] - xyz[j], axis=1)[usable] / turn[usable]
        k = int(np.argmax(ratio))
        if ratio[k] > worst:
            worst, where = float(ratio[k]), (marker, int(group.index[j[usable][k]]))
    if where is not None and worst > MAX_ARC_RADIUS:
        raise InputError(
            f"marker {where[0]} moves as if on a circle of radius {worst:.3g} m or more, beyond any compensator "
            f"({MAX_ARC_RADIUS:g} m): are q2 in deg, not rad?",
            source=source,
            line=where[1],
            column="q2_deg",
        )
