"""The compensator geometry's twin: tracker arcs of a known marker layout, with effects planted in physical terms.

:func:`simulate_markers` measures the compensator markers of a
:class:`~bayescal.geometry.arcs.MarkerLayout` at given joint angles with
isotropic Gaussian noise, with one physical effect planted, each simulated in
its own physical terms rather than in the critique's parametrisation:

* ``tilt``: the compensator's plane rotated in 3D by ``magnitude`` (rad) about
  an in-plane axis through p0 at :data:`TILT_AXIS` from the tracker's X, the
  points then projected on the tracker's XY;
* ``pivot_motion``: the pivot's bracket flexes along the tracker's X only
  under the spring force ``K_c (s - s0)`` along P0→P1 (Table IV's spring:
  :data:`SPRING_K`, :data:`SPRING_S0`), ``magnitude`` its compliance in m/N;
  the cylinder markers turn about the displaced pivot;
* ``cylinder_slip``: the markers' angle from the cylinder's axis grows by
  ``magnitude`` (rad/m) times the spring's extension ``s - s0``;
* ``joint_scale``: the arm's joint 2 turns by ``(1 + magnitude) q2`` where
  ``q2`` is read (a gain error of the angle reading), and every marker with it;
* ``closed_loop``: nothing physical to plant (the closed loop is the same
  layout estimated jointly); the lever marker is measured ``magnitude`` times
  noisier than the cylinder markers, the regime where the loop's information
  on the lever matters;
* ``lever_bending`` (outside the critique's catalogue): the lever marker moves
  along its arc's tangent by ``magnitude`` (m/N) times the spring force
  ``K_c (s - s0)``, as a lever bending under the spring would; the cylinder
  markers still follow the unbent lever axis.

:func:`bayescal_studies.studies.geometry_critique.geometry_detection` runs the geometry critique on
such campaigns.  The markers are placed by :mod:`bayescal.geometry.layout`; the effects are
written here, apart from the critique's parametrisation of its extensions.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from bayescal.geometry.arcs import LEVER_MARKER, MarkerLayout, MarkerPoints
from bayescal.geometry.layout import cylinder_direction, cylinder_points, lever_angle
from bayescal.reference import published
from bayescal.units import DEG, MM, N_PER_MM

__all__ = ["PLANTED", "SPRING_K", "SPRING_S0", "TABLE_I_NOISE", "TILT_AXIS", "simulate_markers"]

TABLE_I_NOISE = 0.05 * MM
"""Tracker noise per coordinate (m) of campaigns simulated like Table I: about the P1 residual scale on Table I."""

SPRING_K = published("IV")["K_c"][0] * N_PER_MM
"""Compensator spring stiffness (N/m): Klimchik et al., Table IV (:func:`bayescal.reference.published`)."""
SPRING_S0 = published("IV")["s0"][0] * MM
"""Spring length (m) at zero force: Klimchik et al., Table IV."""
TILT_AXIS = 60.0 * DEG
"""Direction (rad, from the tracker's X) of the in-plane axis the planted tilt turns about: any direction not
along the arcs' symmetry would do."""

PLANTED = {
    "tilt": (5.0 * DEG, "rad", "tilt of the compensator plane about an in-plane axis"),
    "pivot_motion": (1.5e-8, "m/N", "compliance of the pivot's bracket along X under the spring force"),
    "cylinder_slip": (0.01, "rad/m", "markers' angle from the cylinder axis per metre of spring extension"),
    "joint_scale": (0.004, "", "relative error of the joint-2 angle reading"),
    "closed_loop": (50.0, "x", "lever marker's noise as a multiple of the cylinder markers'"),
    "lever_bending": (2e-8, "m/N", "lever marker's shift along its arc per N of spring force (outside the catalogue)"),
}
"""Each plantable effect: a magnitude the tests find it at on Table I's angles with Table I's noise, its
unit and meaning.  On Table I's layout and angles (spring lengths 512-720 mm, forces 7.7-37.7 kN),
noise-free, the largest residual the two-step model leaves is: ``tilt`` 0.24 mm (P1), 0.16 mm (P01, P02);
``pivot_motion`` 0.19 mm (the pivot moves by up to 0.56 mm); ``cylinder_slip`` 0.19 mm (the markers turn
by up to 0.15°); ``joint_scale`` 0.34 mm (P1), 0.07 mm (P01, P02); ``lever_bending`` 0.20 mm (P1, moved
by up to 0.76 mm).  ``closed_loop`` needs a lever 50× noisier than the cylinder markers: at 5-10× the loop
added nothing measurable in 4 of 4 seeds."""


def simulate_markers(
    layout: MarkerLayout,
    q2: Sequence[float],
    rng: np.random.Generator,
    effect: str | None = None,
    magnitude: float | None = None,
    sigma: float = TABLE_I_NOISE,
) -> MarkerPoints:
    """Tracker points (x, y) of the layout's markers at joint angles ``q2`` (rad) with one planted effect.

    Parameters
    ----------
    layout
        The true marker layout (SI).
    q2
        Joint angles in rad, shape ``(n,)``.
    rng
        Random generator.
    effect
        One of :data:`PLANTED`, or ``None``.
    magnitude
        The effect's size in the unit of :data:`PLANTED` (default its magnitude there).
    sigma
        Noise sd per coordinate (m) of the cylinder markers, and of the lever marker
        unless ``effect`` is ``closed_loop``.

    Returns
    -------
    MarkerPoints
        ``3 n`` points (P1 and each cylinder marker at every angle).
    """
    if effect is not None and effect not in PLANTED:
        raise ValueError(f"unknown effect {effect!r}; expected one of {', '.join(PLANTED)}")
    q2 = np.atleast_1d(np.asarray(q2, dtype=float))
    size = PLANTED[effect][0] if effect is not None and magnitude is None else magnitude
    positions = layout.positions(q2 * (1.0 + size) if effect == "joint_scale" else q2)
    _plant(positions, layout, q2, effect, size)
    names, angles, xyz = [], [], []
    for name, exact in positions.items():
        sd = sigma * size if effect == "closed_loop" and name == LEVER_MARKER else sigma
        names += [name] * q2.size
        angles.append(q2)
        xyz.append(exact + sd * rng.standard_normal(exact.shape))
    return MarkerPoints.from_arrays(np.array(names), np.concatenate(angles), np.vstack(xyz))


def _plant(positions: dict[str, np.ndarray], layout: MarkerLayout, q2: np.ndarray, effect: str | None, size: float) -> None:
    """Move the exact marker positions ``(n, 2)`` (m) in place by a geometric effect (the noise effects act later)."""
    lever = positions[LEVER_MARKER]
    if effect in ("pivot_motion", "cylinder_slip"):
        d = lever - layout.p0
        s = np.linalg.norm(d, axis=1)
        pivot = np.tile(layout.p0, (q2.size, 1))
        slip = np.zeros(q2.size)
        if effect == "pivot_motion":
            force_x = SPRING_K * (s - SPRING_S0) * d[:, 0] / s
            pivot[:, 0] += size * force_x
        else:
            slip = size * (s - SPRING_S0)
        direction = cylinder_direction(lever[:, 0], lever[:, 1], pivot[:, 0], pivot[:, 1])
        for name, (radius, offset) in layout.cylinder.items():
            x, y, _ = cylinder_points(pivot[:, 0], pivot[:, 1], direction, radius, offset, slip)
            positions[name] = np.column_stack([x, y])
    if effect == "lever_bending":
        d = lever - layout.p0
        force = SPRING_K * (np.linalg.norm(d, axis=1) - SPRING_S0)
        angle = lever_angle(layout.phi, layout.sense, q2)
        positions[LEVER_MARKER] = lever + (size * force)[:, np.newaxis] * np.column_stack([-np.sin(angle), np.cos(angle)])
    if effect == "tilt":
        rotation = Rotation.from_rotvec(size * np.array([np.cos(TILT_AXIS), np.sin(TILT_AXIS), 0.0]))
        for name, xy in positions.items():
            planar = np.column_stack([xy - layout.p0, np.zeros(q2.size)])
            positions[name] = layout.p0 + rotation.apply(planar)[:, :2]
