"""Moving tracker-frame files into the frame a model needs, with the registration's uncertainty.

A registration (:func:`bayescal.registration.register`, saved by ``bayescal axes -o``)
gives each frame as ``p_tracker = R p + t``, with the covariance of the rotation
vector ``δθ`` of ``R_true R̂ᵀ`` (tracker axes) and of ``t``.  A point read in the
tracker frame and moved with the estimates ``R̂, t̂`` carries the frame's error, to
first order

    p_true - p̂ = [p̂]× θ - R̂ᵀ δt,        θ = R̂ᵀ δθ (the same turn in the frame's axes),

so its added covariance is ``[p̂]× Σθ [p̂]×ᵀ + R̂ᵀ Σt R̂``: the rotation's sd times the
lever from the frame's origin, plus the translation's.  A deflection
``d = p1 - p0`` loses the translation and keeps ``[d]× Σθ [d]×ᵀ``: a rotation
uncertain by δθ moves a deflection by δθ × d.  (The frames keep the rotation's and
the translation's covariances apart, so their correlation is left out.)

What the models see:

* a campaign: its positions move into the URDF's base frame; its wrench is left
  as it is, since it is computed from the commanded joints in base axes, not read
  by the tracker.  Each row's added deflection variance per coordinate (the
  trace of its 3×3 covariance over 3) joins the tracker's own in
  :attr:`~bayescal.cell.campaign.Campaign.added_variance`, which
  :func:`~bayescal.inference.equations.deflection_noise` adds to every
  equation's noise.  The cell's tracker position is replaced by the one the
  registration measures (``-R̂ᵀ t̂``), so that the distance-dependent noise is the
  tracker's where it stood.
* compensator arcs: their points move into the paper's frame (Klimchik et al.,
  Section IV.A), which ``bayescal geometry`` expects; the added sd of each point
  is reported, not fed to the geometry posterior, whose noise levels are unknowns
  estimated from the arcs' own scatter.  The frame's turn about axis 2 turns the
  whole compensator in its plane, and with it ``(a_x, a_y)`` by that turn times
  ``|a|``; the command reports that sd beside the posterior's.

The rotation error is one turn shared by every reading, not independent per
reading; taken per reading it is averaged down by the number of readings.  It is
kept that way because its size is tiny beside the tracker's noise (measured in
``docs/registration.md``: on a twin registration whose base frame's rotation sd is
0.03-0.12 mrad, the largest sd added to a Table III deflection is 0.64 μm, 1.2 % of
the tracker's; at most 0.70 μm over 8 registrations), and the shift the
registration's own error gives the compliances is measured there too (0.045 sd rms).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.cell.campaign import Campaign, read_campaign
from bayescal.cell.config import Cell
from bayescal.errors import InputError
from bayescal.geometry.arcs import MarkerPoints, read_arc_points
from bayescal.registration.frames import Frame
from bayescal.registration.register import read_frame
from bayescal.units import MM, UM

__all__ = ["CampaignTransfer", "ArcTransfer", "added_covariance", "campaign_to_frame", "arcs_to_frame",
           "read_registered_campaign", "read_registered_arcs"]


def _skew(v: np.ndarray) -> np.ndarray:
    """(n, 3, 3) cross-product matrices ``[v]×`` of (n, 3) vectors."""
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2], s[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    return s - np.swapaxes(s, -1, -2)


def added_covariance(vectors, frame: Frame, *, translation: bool = False) -> np.ndarray:
    """(n, 3, 3) covariance (m²) a frame's uncertainty adds to (n, 3) vectors moved into it.

    Parameters
    ----------
    vectors
        (n, 3) the vectors in the frame, m: points (their lever from the frame's
        origin) or deflections.
    frame
        The registered frame, with its rotation and translation covariances.
    translation
        Add the translation's covariance (points), or not (differences of points).
    """
    v = np.asarray(vectors, dtype=float)
    theta = frame.rotation.T @ frame.rotation_cov @ frame.rotation
    S = _skew(v)
    cov = S @ theta @ np.swapaxes(S, -1, -2)
    if translation:
        cov = cov + frame.rotation.T @ frame.translation_cov @ frame.rotation
    return cov


def _sd_um(cov: np.ndarray) -> np.ndarray:
    """(n,) rms sd per coordinate (μm) of (n, 3, 3) covariances."""
    return np.sqrt(np.trace(cov, axis1=-2, axis2=-1) / 3) / UM


@dataclass(frozen=True)
class CampaignTransfer:
    """A campaign moved from the tracker frame into a registered frame.

    Attributes
    ----------
    campaign
        The campaign in the frame, with the added deflection variance per row (m²).
    frame
        The frame it was moved into.
    tracker_position
        (3,) the tracker's origin in the frame, m.
    deflection_cov, position_cov
        (N, 3, 3) covariances (m²) the frame's uncertainty adds to each row's deflection and unloaded position.
    tracker_sd
        (N,) the tracker's own sd per coordinate of each row's deflection, m.
    """

    campaign: Campaign
    frame: Frame
    tracker_position: np.ndarray
    deflection_cov: np.ndarray
    position_cov: np.ndarray
    tracker_sd: np.ndarray

    def summary(self) -> pd.DataFrame:
        """Per row: the deflection (μm), the sd the frame adds to it and to the position, and the tracker's (μm)."""
        return pd.DataFrame({
            "line": self.campaign.lines, "marker": self.campaign.marker,
            "deflection_um": np.linalg.norm(self.campaign.displacement, axis=1) / UM,
            "deflection_sd_added_um": _sd_um(self.deflection_cov),
            "position_sd_added_um": _sd_um(self.position_cov),
            "tracker_sd_um": self.tracker_sd / UM,
        })

    def diagnostics(self) -> dict:
        """The largest sd added to a deflection and to a position, and the largest ratio of added to tracker sd."""
        table = self.summary()
        return {
            "frame": self.frame.name,
            "tracker_position_mm": (self.tracker_position / MM).tolist(),
            "deflection_sd_added_max_um": float(table["deflection_sd_added_um"].max()),
            "position_sd_added_max_um": float(table["position_sd_added_um"].max()),
            "added_over_tracker_max": float((table["deflection_sd_added_um"] / table["tracker_sd_um"]).max()),
        }

    def to_json(self) -> dict:
        """:meth:`diagnostics`, JSON-ready."""
        return self.diagnostics()

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`summary` as CSV."""
        self.summary().to_csv(path, index=False)


def campaign_to_frame(campaign: Campaign, frame: Frame, cell: Cell) -> tuple[CampaignTransfer, Cell]:
    """Move a campaign read in the tracker frame into ``frame`` (the base frame), and the cell's tracker with it.

    Parameters
    ----------
    campaign
        Positions in the tracker frame, m; wrench in base axes.
    frame
        The registered frame.
    cell
        Its tracker's position is replaced by the registered one.

    Returns
    -------
    CampaignTransfer, Cell
        The campaign in the frame with the added deflection variance, and the cell with its tracker moved.
    """
    moved = replace(campaign, p0=frame.from_tracker(campaign.p0), p1=frame.from_tracker(campaign.p1))
    return _transfer(moved, frame, cell)


def _transfer(moved: Campaign, frame: Frame, cell: Cell) -> tuple[CampaignTransfer, Cell]:
    """The transfer of a campaign already in ``frame``: added covariances, the tracker's place."""
    tracker_position = frame.from_tracker(np.zeros(3))
    deflection_cov = added_covariance(moved.displacement, frame)
    position_cov = added_covariance(moved.p0, frame, translation=True)
    added = np.trace(deflection_cov, axis1=-2, axis2=-1) / 3
    cell = replace(cell, tracker=replace(cell.tracker, position=tracker_position))
    tracker_sd = np.hypot(cell.tracker.sigma(moved.p0), cell.tracker.sigma(moved.p1))
    campaign = replace(moved, added_variance=added)
    return CampaignTransfer(campaign, frame, tracker_position, deflection_cov, position_cov, tracker_sd), cell


def read_registered_campaign(path: str | PathLike[str], cell: Cell, registration: str | PathLike[str]) -> tuple[CampaignTransfer, Cell]:
    """Read a campaign measured in the tracker frame and move it into the registration's base frame.

    The campaign's checks that compare positions with the wrench (markers moving
    along their load) run on the moved positions.

    Raises
    ------
    InputError
        From :func:`~bayescal.registration.read_frame` (no base frame, or a registration not of the cell's robot) or
        :func:`~bayescal.cell.campaign.read_campaign`.
    """
    frame = read_frame(registration, "base", cell)
    return _transfer(read_campaign(path, cell=cell, to_base=frame.from_tracker), frame, cell)


@dataclass(frozen=True)
class ArcTransfer:
    """Compensator arc points moved from the tracker frame into the paper's frame.

    Attributes
    ----------
    points
        The points in the paper's frame (x, y, z), m.
    frame
        The paper's frame.
    position_cov
        (n, 3, 3) covariance (m²) the frame's uncertainty adds to each point.
    """

    points: MarkerPoints
    frame: Frame
    position_cov: np.ndarray

    def summary(self) -> pd.DataFrame:
        """Per point: marker, q2 (deg), position in the paper frame (mm) and the sd the frame adds (μm)."""
        return pd.DataFrame({
            "marker": self.points.marker, "q2_deg": np.degrees(self.points.q2),
            **{f"{c}_mm": self.points.xyz[:, i] / MM for i, c in enumerate("xyz")},
            "sd_added_um": _sd_um(self.position_cov),
        })

    @property
    def turn_sd(self) -> float:
        """sd (rad) of the frame's turn about its Z (axis 2): it turns the whole compensator, a_x and a_y by it times |a|."""
        theta = self.frame.rotation.T @ self.frame.rotation_cov @ self.frame.rotation
        return float(np.sqrt(theta[2, 2]))

    def diagnostics(self) -> dict:
        """The largest and median sd the frame adds to a point (μm), and the sd of its turn about Z (mrad)."""
        sd = _sd_um(self.position_cov)
        return {"frame": self.frame.name, "sd_added_max_um": float(sd.max()), "sd_added_median_um": float(np.median(sd)),
                "turn_about_z_sd_mrad": self.turn_sd * 1e3}

    def to_json(self) -> dict:
        """:meth:`diagnostics`, JSON-ready."""
        return self.diagnostics()

    def save(self, path: str | PathLike[str]) -> None:
        """Write :meth:`summary` as CSV."""
        self.summary().to_csv(path, index=False)


def arcs_to_frame(points: MarkerPoints, frame: Frame) -> ArcTransfer:
    """Move 3D arc points read in the tracker frame into ``frame`` (the paper's).

    Raises
    ------
    InputError
        Planar points (no ``z_mm``): a tracker reads three coordinates, and the
        turn into the paper's frame needs all of them.
    """
    if points.dim != 3:
        raise InputError("points in the tracker frame need z_mm: the turn into the paper's frame uses x, y and z",
                         source=points.source, column="z_mm")
    xyz = frame.from_tracker(points.xyz)
    moved = MarkerPoints.from_arrays(points.marker, points.q2, xyz, line=points.line, source=points.source)
    return ArcTransfer(moved, frame, added_covariance(xyz, frame, translation=True))


def read_registered_arcs(path: str | PathLike[str], registration: str | PathLike[str]) -> ArcTransfer:
    """Read compensator arcs measured in the tracker frame and move them into the registration's paper frame."""
    frame = read_frame(registration, "paper")
    return arcs_to_frame(read_arc_points(path), frame)
