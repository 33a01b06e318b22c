"""Priors of the compensator geometry for the elastostatic identification.

The geometry ``[L, a_x, a_y, phi]`` enters the joint-2 stiffness of eq 8.  Its
prior is Gaussian: from a saved geometry posterior (the first step of the
paper's method) or, without one, centred on the cell's compensator with the
uncertainties of Klimchik et al., Table II.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from bayescal.errors import InputError
from bayescal.robot.compensator import CompensatorGeometry
from bayescal.units import DEG, MM

__all__ = ["GeometryPrior", "posterior_geometry", "config_geometry", "TABLE_II_SD", "PHI_SD"]


@dataclass(frozen=True)
class GeometryPrior:
    """Gaussian prior of the compensator geometry ``[L, a_x, a_y, phi]`` (m, m, m, rad).

    A zero covariance fixes the geometry at ``mean``.
    """

    mean: np.ndarray
    cov: np.ndarray
    source: str = ""

    @cached_property
    def fixed(self) -> bool:
        """True when the geometry is not sampled."""
        return not np.any(self.cov)

    @classmethod
    def from_draws(cls, draws: np.ndarray, source: str = "") -> GeometryPrior:
        """Mean and covariance of geometry draws ``(n, 4)`` (e.g. a geometry posterior)."""
        draws = np.asarray(draws, dtype=float)
        return cls(mean=draws.mean(axis=0), cov=np.cov(draws, rowvar=False), source=source)

    @cached_property
    def _precision(self) -> np.ndarray:
        return np.linalg.inv(self.cov)

    def log_density(self, geometry: np.ndarray) -> np.ndarray | float:
        """Log-density up to a constant of ``(..., 4)`` geometries (0 when fixed)."""
        if self.fixed:
            return 0.0
        d = np.asarray(geometry, dtype=float) - self.mean
        value = -0.5 * np.einsum("...i,ij,...j->...", d, self._precision, d)
        return float(value) if np.ndim(value) == 0 else value


TABLE_II_SD = np.array([0.06, 0.70, 0.69]) / 3 * MM
"""Standard deviations of L, a_x, a_y: Klimchik et al., Table II's ±3σ half-widths divided by 3."""
PHI_SD = 0.05 * DEG
"""Standard deviation of the lever angle phi when no geometry posterior is given: an ESTIMATE
(Table II gives none); the arc fits of the geometry step determine phi to a few hundredths of a degree."""


def posterior_geometry(path) -> GeometryPrior:
    """Geometry prior from a saved geometry posterior (NetCDF with L, a_x, a_y in mm and phi in deg).

    The Gaussian with the draws' mean and covariance: the elastostatic data then
    barely move it, and the same prior serves the Gibbs and the emcee paths.
    """
    from bayescal.sampling.summary import load

    try:
        tree = load(path)
        posterior = tree["posterior"]
    except (OSError, KeyError, ValueError) as exc:
        raise InputError(f"cannot read a geometry posterior ({type(exc).__name__})", source=str(path)) from None
    columns = []
    for name, factor in (("L", MM), ("a_x", MM), ("a_y", MM), ("phi", DEG)):
        if name not in posterior:
            tree.close()
            raise InputError(f"the geometry posterior has no variable '{name}'", source=str(path), column=name)
        columns.append(np.asarray(posterior[name].values, dtype=float).reshape(-1) * factor)
    tree.close()
    draws = np.column_stack(columns)
    spread = draws.std(axis=0)
    if np.any(spread <= 1e-9 * np.abs(draws.mean(axis=0))) or np.linalg.matrix_rank(np.corrcoef(draws, rowvar=False)) < 4:
        raise InputError(
            "the geometry posterior's draws of L, a_x, a_y, phi have a singular covariance (a constant or duplicated variable)",
            source=str(path),
        )
    return GeometryPrior.from_draws(draws, source=f"geometry posterior {path}")


def config_geometry(compensator: CompensatorGeometry, source: str = "") -> GeometryPrior:
    """Gaussian geometry prior centred on a config's compensator with Table II's uncertainties (and :data:`PHI_SD`)."""
    mean = np.array([compensator.L, compensator.a_x, compensator.a_y, compensator.phi])
    sd = np.concatenate([TABLE_II_SD, [PHI_SD]])
    return GeometryPrior(mean=mean, cov=np.diag(sd**2), source=f"{source} with Klimchik et al. Table II ±3σ/3".strip())


