"""Unit conversions between the SI values used inside and the paper's units at the edges.

Inside the package every quantity is SI (m, rad, N, N·m, N/m, rad/(N·m)).
Files, tables and the CLI use the paper's units: mm, deg, N, N·m, joint
compliances in μrad/(N·m), compensator stiffness in N/mm and lengths in mm.
"""

from __future__ import annotations

import math

__all__ = ["MM", "DEG", "URAD_PER_NM", "UM_PER_N", "N_PER_MM", "UM", "HOUR"]

MM = 1e-3
"""One millimetre in metres."""
UM = 1e-6
"""One micrometre in metres."""
DEG = math.pi / 180.0
"""One degree in radians."""
URAD_PER_NM = 1e-6
"""One μrad/(N·m) in rad/(N·m): the paper's unit of joint compliance."""
UM_PER_N = 1e-6
"""One μm/N in m/N: the unit of a prismatic joint's compliance (a linear track's)."""
N_PER_MM = 1e3
"""One N/mm in N/m: the unit of the compensator spring stiffness K_c."""
HOUR = 3600.0
"""One hour in seconds: the unit of a drift's rate (mm/h)."""
