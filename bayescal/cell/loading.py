"""What a cell's calibration end-effector can apply: hanging masses only, or forces and couples in any direction.

A load is a force ``f`` (N, base axes) acting through the tool's load point and
a couple ``c`` (N·m, base axes).  Klimchik et al. hang masses (``f`` straight
down, no couple), but their Fig. 5 end-effector "allows to generate both forces
and torques", and their design problem (eq 40) minimises over the loadings
subject to ``‖F‖ < F_max`` (eq 41).  A force applied through a cable and pulley
or a jack against a fixture keeps its direction in the base axes while the arm
deflects, as a hanging mass does; that is how the twin and the models treat it.

The cell file's ``[load]`` table says which kind its end-effector is:
``directions = "down"`` (the default: masses only) or ``"any"``, ``force_max_N``
(eq 41's ``F_max``; required with ``"any"``) and ``couple_max_Nm`` (0 or absent:
no couples).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DIRECTIONS", "Loading", "MAX_LOAD_ARM", "VERTICAL_TOLERANCE", "WRENCH_COLUMNS", "WRITTEN_RESOLUTION"]

WRENCH_COLUMNS = ("fx_N", "fy_N", "fz_N", "mx_Nm", "my_Nm", "mz_Nm")
"""The columns of a load in every file that carries one: the wrench at the flange origin in base axes."""
MAX_LOAD_ARM = 2.0
"""Farthest (m) a load can plausibly act from the flange: the length of a long tool.

The KR-270 cell hangs its load 0.39 m from the flange (``data/kr270.toml``).  A
moment that needs a longer arm for its force is a moment column in N·mm."""

DIRECTIONS = ("down", "any")
"""The kinds of end-effector a cell file may declare in ``[load] directions``."""

VERTICAL_TOLERANCE = 1e-3
"""Largest horizontal part of a force, as a fraction of its size, still taken as vertical: a plan
file writes forces with 0.1 N resolution, 3e-5 of a 250 kg weight, and a sling hangs within a
milliradian only if nothing pushes it; anything larger is a load a hanging mass cannot apply."""

WRITTEN_RESOLUTION = 0.1
"""Slack (N, N·m) of the limits: plan files write each component to 0.1, so a force designed at
``F_max`` may come back up to √3·0.05 ≈ 0.09 above it."""


@dataclass(frozen=True)
class Loading:
    """The loads a cell's end-effector can apply, SI.

    Attributes
    ----------
    directions : str
        ``"down"`` (hanging masses only) or ``"any"``.
    force_max : float or None
        Largest force, N (eq 41's ``F_max``); ``None`` leaves it to the plausibility bound of the cell.
    couple_max : float
        Largest couple, N·m; 0 when the end-effector applies none.
    """

    directions: str = "down"
    force_max: float | None = None
    couple_max: float = 0.0

    def __post_init__(self) -> None:
        if self.directions not in DIRECTIONS:
            raise ValueError(f"directions must be one of {', '.join(DIRECTIONS)}, got {self.directions!r}")

    @property
    def hanging_only(self) -> bool:
        """True when the end-effector can only hang masses (every force points straight down)."""
        return self.directions == "down"

    def force_violation(self, force) -> str | None:
        """Why the end-effector cannot apply ``force`` (3,) N, base axes, or ``None`` when it can."""
        force = np.asarray(force, dtype=float).reshape(3)
        size = float(np.linalg.norm(force))
        if self.force_max is not None and size > self.force_max + WRITTEN_RESOLUTION:
            return f"a force of {size:.1f} N is more than the end-effector's force_max_N = {self.force_max:g} N (eq 41's F_max)"
        if self.hanging_only and size > 0:
            horizontal = math.hypot(force[0], force[1])
            if force[2] > 0 or horizontal > VERTICAL_TOLERANCE * size:
                return (
                    f"the force [{force[0]:.1f}, {force[1]:.1f}, {force[2]:.1f}] N is not straight down, and the cell's "
                    'end-effector hangs masses only ([load] directions = "down")'
                )
        return None

    def couple_violation(self, couple) -> str | None:
        """Why the end-effector cannot apply ``couple`` (3,) N·m, base axes, or ``None`` when it can."""
        size = float(np.linalg.norm(np.asarray(couple, dtype=float)))
        if size == 0:
            return None
        if self.couple_max <= 0:
            return f"a couple of {size:.1f} N m, and the cell's end-effector applies none ([load] couple_max_Nm is 0 or absent)"
        if size > self.couple_max + WRITTEN_RESOLUTION:
            return f"a couple of {size:.1f} N m is more than the end-effector's couple_max_Nm = {self.couple_max:g} N m"
        return None
