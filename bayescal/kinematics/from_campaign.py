"""Absolute positions out of an elastostatic campaign: each configuration's readings as a positions file's rows.

A campaign (``bayescal calibrate``'s input) reads every marker of the tool
unloaded and loaded, in the robot's base frame; its unloaded readings are the
absolute positions a kinematic calibration fits the geometry to, several
measured points (the tool's reflectors) per configuration.  One repeat is taken:
a positions file has one row per marker per configuration, and the tracker's
noise law of the points cell is that of one reading.
"""

from __future__ import annotations

from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign
from bayescal.errors import InputError
from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.positions import POSITION_COLUMNS, Positions
from bayescal.units import DEG, MM

__all__ = ["campaign_positions", "write_positions"]


def campaign_positions(campaign: Campaign, cell: PointsCell, *, repeat: int | None = None,
                       loaded: bool = False) -> tuple[Positions, np.ndarray, np.ndarray | None]:
    """The readings of one repeat of every configuration, markers in ``cell``'s order, the wrenches and the load points.

    Parameters
    ----------
    campaign
        The campaign; its joints are ``cell``'s commanded joints, in order.
    cell
        The cell of measured points; each of its markers must be in every configuration.
    repeat
        The repeat taken (default: each configuration's first).
    loaded
        Take the loaded readings instead of the unloaded ones.

    Returns
    -------
    positions : Positions
    wrenches : numpy.ndarray
        ``(N, 6)`` each configuration's load (N, N·m) at the flange origin, base axes.
    load_points : numpy.ndarray or None
        ``(N, 3)`` where each configuration's load hangs (flange frame, m), when the campaign gives it.
    """
    if campaign.q.shape[1] != len(cell.commanded):
        raise InputError(f"the campaign has {campaign.q.shape[1]} joint columns; the cell {cell.source} commands "
                         f"{len(cell.commanded)}", source=campaign.source)
    configs = np.unique(campaign.config)
    rows = []
    for config in configs:
        mine = campaign.config == config
        chosen = campaign.repeat[mine].min() if repeat is None else repeat
        index = np.flatnonzero(mine & (campaign.repeat == chosen))
        names = list(campaign.marker[index])
        missing = [name for name in cell.marker_names if name not in names]
        if missing:
            raise InputError(f"configuration {config} has no reading of marker '{missing[0]}' in repeat {chosen}",
                             source=campaign.source, column="marker")
        rows.append([index[names.index(name)] for name in cell.marker_names])
    rows = np.array(rows)
    xyz = (campaign.p1 if loaded else campaign.p0)[rows]
    positions = Positions(joints=campaign.q[rows[:, 0]], xyz=xyz, lines=campaign.lines[rows], rows=np.arange(rows.size).reshape(rows.shape),
                          source=campaign.source)
    return positions, campaign.wrench[rows[:, 0]], None if campaign.load_point is None else campaign.load_point[rows[:, 0]]


def write_positions(path: str | PathLike[str], campaign: Campaign, columns: tuple[str, ...], *, comments: tuple[str, ...] = ()) -> None:
    """Write the first repeat's unloaded readings of ``campaign`` as a positions file.

    ``columns`` names the joint columns (``q1_deg..qn_deg``); the rows run over configurations, then markers in the
    campaign's order, with 6 decimals in deg and 5 in mm (10 nm), as the campaign files.
    """
    first = np.array([campaign.repeat[campaign.config == c].min() for c in campaign.config])
    rows = np.flatnonzero(campaign.repeat == first)
    frame = pd.DataFrame((campaign.q[rows] / DEG).round(6), columns=list(columns))
    frame["marker"] = campaign.marker[rows]
    frame[list(POSITION_COLUMNS)] = (campaign.p0[rows] / MM).round(5)
    with open(path, "w", newline="") as out:
        for line in comments:
            out.write(f"# {line}\n")
        frame.to_csv(out, index=False)
