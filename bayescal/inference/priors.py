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
from bayescal.inference.parameters import GEOMETRY_PARAMETERS, is_per_angle_variable
from bayescal.reference import published
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


TABLE_II_SD = np.array([published("II")[name][1] for name in ("L", "a_x", "a_y")]) / 3 * MM
"""Standard deviations of L, a_x, a_y (m): Klimchik et al., Table II's ±3σ half-widths (``data/paper_reference.csv``)
divided by 3."""
PHI_SD = 0.05 * DEG
"""Standard deviation of the lever angle phi when no geometry posterior is given: an ESTIMATE
(Table II gives none); the arc fits of the geometry step determine phi to a few hundredths of a degree."""


MAX_GEOMETRY_OFFSET = 0.5
"""Largest difference between a geometry posterior's L or |(a_x, a_y)| and the cell's, as a fraction of the
cell's value, and (times 60 deg) of phi: the twin's and Table II's geometries differ by under 1 %, a value in
m instead of mm by 99.9 %, phi in rad instead of deg by 98 %."""


def posterior_geometry(path, expected: CompensatorGeometry | None = None) -> GeometryPrior:
    """Geometry prior from a saved geometry posterior (NetCDF with L, a_x, a_y in mm and phi in deg).

    The Gaussian with the draws' mean and covariance: the elastostatic data then
    barely move it, and the same prior serves the Gibbs and the emcee paths.

    Parameters
    ----------
    path
        The NetCDF DataTree `bayescal geometry --posterior` writes.
    expected
        The cell's compensator geometry (m, rad); when given, a posterior far from it (in metres or
        radians, or of another robot) is refused.

    Raises
    ------
    InputError
        For a file that is not a geometry posterior (an elastostatic posterior included), a variable
        missing, in another unit or with non-finite draws, a singular covariance, or a mean far from ``expected``.
    """
    from bayescal.sampling.summary import read_posterior

    tree, posterior = read_posterior(path, "a geometry posterior")
    per_angle = [str(name) for name in posterior.data_vars if is_per_angle_variable(str(name))]
    if per_angle:
        tree.close()
        raise InputError(
            f"this is an elastostatic posterior (it has '{per_angle[0]}'); expected the geometry posterior `bayescal geometry --posterior` writes",
            source=str(path),
        )
    columns = []
    for parameter in GEOMETRY_PARAMETERS:
        name, unit = parameter.name, parameter.unit
        if name not in posterior:
            tree.close()
            raise InputError(f"the geometry posterior has no variable '{name}'", source=str(path), column=name)
        given = posterior[name].attrs.get("units", unit)
        values = np.asarray(posterior[name].values, dtype=float).reshape(-1)
        if given != unit or not np.all(np.isfinite(values)):
            tree.close()
            problem = f"is in {given}" if given != unit else f"has {np.count_nonzero(~np.isfinite(values))} non-finite draws"
            raise InputError(f"the variable {problem}; expected finite draws in {unit}", source=str(path), column=name)
        columns.append(parameter.to_si(values))
    tree.close()
    draws = np.column_stack(columns)
    spread = draws.std(axis=0)
    if np.any(spread <= 1e-9 * np.abs(draws.mean(axis=0))) or np.linalg.matrix_rank(np.corrcoef(draws, rowvar=False)) < 4:
        raise InputError(
            "the geometry posterior's draws of L, a_x, a_y, phi have a singular covariance (a constant or duplicated variable)",
            source=str(path),
        )
    if expected is not None:
        _check_near(draws.mean(axis=0), expected, str(path))
    return GeometryPrior.from_draws(draws, source=f"geometry posterior {path}")


def _check_near(mean: np.ndarray, expected: CompensatorGeometry, source: str) -> None:
    """Refuse a geometry posterior mean ``[L, a_x, a_y, phi]`` (m, rad) far from the cell's compensator."""
    L, a, phi = mean[0], float(np.hypot(mean[1], mean[2])), mean[3]
    cell_a = float(np.hypot(expected.a_x, expected.a_y))
    for name, value, reference in (("L", L, expected.L), ("a_x", a, cell_a)):
        if abs(value - reference) > MAX_GEOMETRY_OFFSET * reference:
            in_m = abs(value * 1000 - reference) < MAX_GEOMETRY_OFFSET * reference
            what = "L" if name == "L" else "|(a_x, a_y)|"
            raise InputError(
                f"the geometry posterior's {what} is {value / MM:.6g} mm, far from the cell's compensator's "
                f"{reference / MM:.6g} mm: {'is it in m instead of mm?' if in_m else 'is it the posterior of this robot?'}",
                source=source,
                column=name,
            )
    turn = abs((phi - expected.phi + np.pi) % (2 * np.pi) - np.pi)
    if turn > MAX_GEOMETRY_OFFSET * 60 * DEG:
        in_rad = abs((phi / DEG - expected.phi + np.pi) % (2 * np.pi) - np.pi) < MAX_GEOMETRY_OFFSET * 60 * DEG
        raise InputError(
            f"the geometry posterior's phi is {phi / DEG:.6g} deg, {turn / DEG:.3g} deg from the cell's compensator's "
            f"{expected.phi / DEG:.6g} deg{': is it in rad instead of deg?' if in_rad else ': is it the posterior of this robot?'}",
            source=source,
            column="phi",
        )


def config_geometry(compensator: CompensatorGeometry, source: str = "") -> GeometryPrior:
    """Gaussian geometry prior centred on a config's compensator with Table II's uncertainties (and :data:`PHI_SD`)."""
    mean = np.array([compensator.L, compensator.a_x, compensator.a_y, compensator.phi])
    sd = np.concatenate([TABLE_II_SD, [PHI_SD]])
    return GeometryPrior(mean=mean, cov=np.diag(sd**2), source=f"{source} with Klimchik et al. Table II ±3σ/3".strip())


