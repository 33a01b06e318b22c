"""How well the cylinder markers of a tracker campaign fix the compensator's pivot p0.

The cylinder markers trace arcs about p0 over only the cylinder's swing, so
each arc alone fixes its centre poorly.  :func:`cylinder_marker_study` says
what each marker alone would give for ``a_y``, how its radial residuals of the
concentric fit run with q2, and how far its angle about p0 (measured from the
direction p0→P1) drifts, which a marker rigid on the cylinder would not do.
:func:`along_arc_residuals` projects residuals on the arcs' tangents, the
component the concentric model leaves free; :func:`implied_cylinder_noise`
scales the posterior's cylinder-marker noise to the width of published intervals.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bayescal.geometry.arcs import LEVER_MARKER, GeometryFit, MarkerLayout, MarkerPoints, concentric_fit
from bayescal.geometry.layout import cylinder_direction, marker_offset
from bayescal.units import DEG, MM

__all__ = ["along_arc_residuals", "cylinder_marker_study", "implied_cylinder_noise"]


def cylinder_marker_study(points: MarkerPoints, closed: GeometryFit) -> pd.DataFrame:
    """Each cylinder marker on its own: its centre, its residuals' pattern and its angular drift about p0.

    Parameters
    ----------
    points
        The campaign's marker points.
    closed
        The closed-form fit of the same points.

    Returns
    -------
    pandas.DataFrame
        Indexed by marker, columns ``a_y_alone_mm`` (``a_y`` with p0 fitted to
        that marker alone, in the frame of the combined fit), ``residual_rms_mm``
        (of the concentric fit, radial), ``residual_correlation`` (correlation
        of its radial residuals with the other markers' mean, at matching q2
        order), ``drift_deg`` (range of its angle about p0 from the direction
        p0→P1 over the campaign) and ``drift_along_arc_mm`` (that range along its arc).
    """
    layout = MarkerLayout.from_fit(closed, points)
    # a_y follows the frame of the combined fit, which flips y when the arc turns the other way.
    flip = -1.0 if closed.mirrored else 1.0
    ordered = {name: closed.cylinder.residuals[name][np.argsort(points.of(name)[0])] for name in points.cylinder_markers}
    rows = {}
    for name in points.cylinder_markers:
        q2, xyz = points.of(name)
        single = concentric_fit({name: xyz[:, :2]})
        lever = layout.positions(q2)[LEVER_MARKER]
        direction = cylinder_direction(lever[:, 0], lever[:, 1], layout.p0[0], layout.p0[1])
        relative = np.angle(np.exp(1j * marker_offset(xyz[:, 0], xyz[:, 1], layout.p0[0], layout.p0[1], direction)))
        drift = float(np.ptp(np.unwrap(relative)))
        others = [residual for other, residual in ordered.items() if other != name and residual.size == ordered[name].size]
        correlation = float(np.corrcoef(ordered[name], np.mean(others, axis=0))[0, 1]) if others else np.nan
        rows[name] = {
            "a_y_alone_mm": flip * (closed.p2[1] - single.centre[1]) / MM,
            "residual_rms_mm": closed.residuals_rms[name] / MM,
            "residual_correlation": correlation,
            "drift_deg": drift / DEG,
            "drift_along_arc_mm": drift * closed.cylinder.radii[name] / MM,
        }
    frame = pd.DataFrame.from_dict(rows, orient="index")
    frame.index.name = "marker"
    return frame


def along_arc_residuals(points: MarkerPoints, p0: np.ndarray, name: str, residual: np.ndarray) -> np.ndarray:
    """``(n,)`` component (m) of a marker's ``(n, 2)`` residuals along the tangent of its arc about ``p0`` (m, ``(2,)``)."""
    _, xyz = points.of(name)
    d = xyz[:, :2] - p0
    tangent = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
    return np.sum(residual * tangent, axis=1)


def implied_cylinder_noise(summary: pd.DataFrame, published: pd.DataFrame, names: tuple[str, ...] = ("a_x", "a_y")) -> pd.Series:
    """The cylinder markers' noise sd (mm) at which our intervals of ``names`` would be as wide as the published ones.

    The posterior sd of ``a_x`` and ``a_y`` scales with the cylinder markers'
    noise ``sigma[cylinder]``; scaling it by the ratio of the published σ (a
    third of the ±3σ half-width) to our sd gives the noise the published
    intervals correspond to.

    Parameters
    ----------
    summary
        The concentric posterior's summary (``mean``, ``sd`` by parameter, mm).
    published
        :func:`~bayescal.reference.beside_published` of the same posterior.
    """
    sigma = summary.loc["sigma[cylinder]", "mean"]
    return pd.Series(
        {name: sigma * (published.loc[name, "published_half_width_3sd"] / 3) / summary.loc[name, "sd"] for name in names},
        name="sigma_cylinder_mm",
    )
