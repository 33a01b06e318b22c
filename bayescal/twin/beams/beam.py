"""Links as Timoshenko beams: cross-sections and the compliance of a cantilever loaded at its tip.

A beam element runs along its local x axis from its root (clamped) to its tip; a
wrench ``[f; m]`` at the tip, in the tip's axes and about the tip's centre, moves the
tip by ``[δ; φ]`` (translation, small rotation) = ``C [f; m]``, with the closed forms of
a prismatic Timoshenko beam (bending plus shear, axial stretch, Saint-Venant torsion):

    δy = f_y ℓ³/(3 E I_z) + f_y ℓ/(G A_sy) + m_z ℓ²/(2 E I_z),    φz = f_y ℓ²/(2 E I_z) + m_z ℓ/(E I_z)
    δz = f_z ℓ³/(3 E I_y) + f_z ℓ/(G A_sz) − m_y ℓ²/(2 E I_y),    φy = −f_z ℓ²/(2 E I_y) + m_y ℓ/(E I_y)
    δx = f_x ℓ/(E A),    φx = m_x ℓ/(G J)

where ``A_s`` are the shear areas (the section's area times its shear coefficient).
Elements in series, each loaded at its nodes, give the beam's exact deflection under
point loads, which is how a link's own weight enters (a node at its centre of mass).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["Section", "box_section", "tube_section", "timoshenko_compliance"]


@dataclass(frozen=True)
class Section:
    """A prismatic beam's cross-section and material, SI units.

    Attributes
    ----------
    E, G : float
        Young's and shear moduli, Pa.
    area : float
        Cross-section area, m².
    I_y, I_z : float
        Second moments of area about the section's y and z axes, m⁴.
    J : float
        Torsion constant, m⁴.
    shear_y, shear_z : float
        Shear areas for forces along y and z, m².
    """

    E: float
    G: float
    area: float
    I_y: float
    I_z: float
    J: float
    shear_y: float
    shear_z: float

    def softened(self, factor: float) -> Section:
        """The same section with both moduli divided by ``factor`` (> 0): every compliance times ``factor``."""
        return replace(self, E=self.E / factor, G=self.G / factor)


def box_section(width: float, height: float, wall: float, E: float, G: float) -> Section:
    """A thin-walled rectangular tube: ``width`` along the section's y, ``height`` along z, all in m.

    The torsion constant is Bredt's ``4 A_m² t / perimeter_m`` (``A_m`` enclosed by the wall's
    mid-line); the shear area of a force along z is the two walls parallel to it, ``2 t h``.
    """
    inner_w, inner_h = width - 2 * wall, height - 2 * wall
    if inner_w <= 0 or inner_h <= 0:
        raise ValueError(f"box_section: wall {wall} m leaves no hollow in {width} x {height} m")
    mid_w, mid_h = width - wall, height - wall
    return Section(
        E=E,
        G=G,
        area=width * height - inner_w * inner_h,
        I_y=(width * height**3 - inner_w * inner_h**3) / 12,
        I_z=(height * width**3 - inner_h * inner_w**3) / 12,
        J=4 * (mid_w * mid_h) ** 2 * wall / (2 * (mid_w + mid_h)),
        shear_y=2 * wall * width,
        shear_z=2 * wall * height,
    )


THIN_TUBE_SHEAR_COEFFICIENT = 0.5
"""Shear coefficient of a thin-walled circular tube (Timoshenko's value for a thin ring section)."""


def tube_section(outer_diameter: float, wall: float, E: float, G: float) -> Section:
    """A circular tube (diameters and wall in m); its shear areas are half its area."""
    inner = outer_diameter - 2 * wall
    if inner <= 0:
        raise ValueError(f"tube_section: wall {wall} m leaves no hollow in a {outer_diameter} m tube")
    area = math.pi / 4 * (outer_diameter**2 - inner**2)
    second = math.pi / 64 * (outer_diameter**4 - inner**4)
    shear = THIN_TUBE_SHEAR_COEFFICIENT * area
    return Section(E=E, G=G, area=area, I_y=second, I_z=second, J=2 * second, shear_y=shear, shear_z=shear)


def timoshenko_compliance(length: float, section: Section) -> np.ndarray:
    """(6, 6) compliance of a cantilever of ``length`` (m): tip ``[δ (m); φ (rad)]`` per tip ``[f (N); m (N·m)]``.

    Symmetric and positive definite (Maxwell–Betti); formulas in the module documentation.
    """
    l, E, G = length, section.E, section.G
    C = np.zeros((6, 6))
    C[0, 0] = l / (E * section.area)
    C[3, 3] = l / (G * section.J)
    # Bending in the x-y plane: force f_y, moment m_z.
    C[1, 1] = l**3 / (3 * E * section.I_z) + l / (G * section.shear_y)
    C[1, 5] = C[5, 1] = l**2 / (2 * E * section.I_z)
    C[5, 5] = l / (E * section.I_z)
    # Bending in the x-z plane: force f_z, moment m_y (a force along +z turns the tip about −y).
    C[2, 2] = l**3 / (3 * E * section.I_y) + l / (G * section.shear_z)
    C[2, 4] = C[4, 2] = -(l**2) / (2 * E * section.I_y)
    C[4, 4] = l / (E * section.I_y)
    return C
