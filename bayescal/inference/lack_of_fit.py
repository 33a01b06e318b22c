"""Lack of fit against pure error: does the model explain the configurations as well as the repeats allow?

A campaign of the paper's kind measures every configuration several times
(Table III: three repeats).  The scatter of one marker's repeated deflections
about their own mean measures the tracker noise with no model at all (the
*pure error*); the scatter of the configuration means about the fitted model
adds whatever the model gets wrong.  The classical lack-of-fit test (Draper and
Smith, *Applied Regression Analysis*, 3rd ed., section 2.1) compares the two::

    F = (SS_lof / dof_lof) / (SS_pe / dof_pe),   SS_res = SS_lof + SS_pe

where a *cell* is one coordinate of one marker in one configuration, ``SS_pe``
sums the squared deviations of its repeats from the cell mean, ``SS_lof`` the
squared cell means of the residuals (times the number of repeats), each
weighted by the tracker noise model's relative variance of the cell, and
``dof_lof = cells - parameters``, ``dof_pe = readings - cells``.  Under the
model, ``F`` follows the F distribution with ``(dof_lof, dof_pe)`` degrees of
freedom whatever the noise level, which need not be known.

What it assumes:

* the repeats of one configuration see the same deflection: the load is
  re-applied to the same arm at the same joint angles.  Scatter that the
  repeats do not share (re-hanging the load at a slightly different point,
  tracker drift between configurations) counts as lack of fit, as it should:
  the model does not describe it;
* the tracker noise model gives each cell's variance up to one common factor
  (the cell file's distance law); a noise model far off in its *shape* makes the
  test conservative or liberal;
* residuals are taken at one parameter value with ``parameters`` free
  coefficients (the least-squares fit, or a posterior mean under a weak prior).

Without repeats there is no pure error: :func:`lack_of_fit` returns ``None``, and
the caller falls back on the residuals against the configured noise level
(χ²/dof), which cannot tell a misfit from a tracker noisier than configured.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bayescal.inference.identifiability import independent_columns

__all__ = ["LackOfFit", "LACK_OF_FIT_LEVEL", "lack_of_fit", "least_squares_lack_of_fit", "line_of_sight", "group_scales", "replicate_cells"]

LACK_OF_FIT_LEVEL = 0.01
"""p-value below which a lack of fit is reported (``calibrate`` warns, ``critique`` calls a misfit).

One per cent rather than five so that a campaign without any effect is called a
misfit by this test alone in one campaign of a hundred; the test's size at both
levels is measured in ``docs/critique.md``."""


@dataclass(frozen=True)
class LackOfFit:
    """The lack-of-fit F test of a fitted campaign.

    Attributes
    ----------
    statistic : float
        ``F``, the lack-of-fit mean square over the pure-error mean square.
    p_value : float
        Upper tail of the statistic's reference distribution at the statistic: ``F(dof_lof, dof_pe)``,
        or ``c·F(dof_lof, ν)`` when each direction is weighted by its own pure error (:func:`lack_of_fit`).
    dof : tuple of int
        ``(dof_lof, dof_pe)``, or ``(dof_lof, ν)`` with ``ν`` the matched reference's (below ``dof_pe``).
    null_mean : float
        The statistic's mean under the model (``dof_pe / (dof_pe - 2)`` for the plain test).
    factor : float
        ``sqrt(F)``: how many times the scatter of the configuration means about the
        model exceeds what the repeats' own scatter predicts.
    """

    statistic: float
    p_value: float
    dof: tuple[int, int]
    null_mean: float = float("nan")

    @property
    def factor(self) -> float:
        return float(np.sqrt(max(self.statistic, 0.0)))

    def significant(self, level: float = LACK_OF_FIT_LEVEL) -> bool:
        """Whether the model misses the configuration means at ``level``."""
        return self.p_value < level

    def describe(self) -> str:
        """One line for a person: the factor and the p-value."""
        return (
            f"the configuration means scatter {self.factor:.2f} times as much about the model as the repeats allow "
            f"(lack-of-fit F = {self.statistic:.2f} on {self.dof[0]} and {self.dof[1]} degrees of freedom, p = {self.p_value:.2g})"
        )

    def to_json(self) -> dict:
        return {"statistic": self.statistic, "p_value": self.p_value, "dof": list(self.dof), "factor": self.factor}


def replicate_cells(config: np.ndarray, marker: np.ndarray) -> np.ndarray:
    """``(3 N,)`` labels of the cells of a campaign's equations: one per configuration, marker and coordinate.

    Parameters
    ----------
    config, marker
        ``(N,)`` each row's configuration label and marker name; the equations are
        the rows' three coordinates in order (``x, y, z`` of row 0, then row 1 …).
    """
    _, rows = np.unique(np.column_stack([np.asarray(config).astype(str), np.asarray(marker).astype(str)]), axis=0, return_inverse=True)
    return (3 * rows.reshape(-1)[:, None] + np.arange(3)).reshape(-1)


def group_scales(values: np.ndarray, scale: np.ndarray, cells: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """``scale`` times each group's own pure-error sd relative to the groups' mean: weights from the repeats alone.

    Parameters
    ----------
    values
        ``(n,)`` the observations (or any residuals: only their deviations from the cell means enter).
    scale
        ``(n,)`` the noise model's sd of each equation, up to a common factor.
    cells
        ``(n,)`` cell labels (:func:`replicate_cells`); every cell lies within one group.
    groups
        ``(n,)`` labels of the groups whose variance is estimated apart (e.g. the directions of a reading).

    Returns
    -------
    numpy.ndarray
        ``(n,)`` the rescaled sd; ``scale`` unchanged when a group has no repeats.  A
        :func:`lack_of_fit` on residuals weighted so must be told the same ``groups``.
    """
    relative = np.asarray(values, dtype=float) / scale
    _, index, counts = np.unique(cells, return_inverse=True, return_counts=True)
    _, group = np.unique(groups, return_inverse=True)
    deviation = relative - (np.bincount(index, weights=relative) / counts)[index]
    dof = np.bincount(group, weights=(counts[index] - 1) / counts[index])
    if np.any(dof <= 0):
        return np.asarray(scale, dtype=float)
    variance = np.bincount(group, weights=deviation**2) / dof
    return scale * np.sqrt(variance[group] / variance.mean())


def lack_of_fit(
    residual: np.ndarray, scale: np.ndarray, cells: np.ndarray, n_parameters: int, groups: np.ndarray | None = None
) -> LackOfFit | None:
    """The lack-of-fit F test of residuals about a fitted model, or None without repeats.

    Parameters
    ----------
    residual
        ``(n,)`` residuals of the equations (any unit).
    scale
        ``(n,)`` the noise model's sd of each equation, same unit up to a common factor.
    cells
        ``(n,)`` cell labels (:func:`replicate_cells`): equations of one cell are repeats.
    n_parameters
        Free coefficients of the fit the residuals come from.
    groups
        ``(n,)`` when ``scale`` comes from :func:`group_scales`, its groups.  Each group's weight
        then rests on its own pure error, the statistic is a sum of one ratio per group, and its
        mean is ``b/(b-2)`` for ``b`` a group's pure-error degrees of freedom rather than the
        pooled ``dof_pe``'s: the p-value is taken from ``c·F(dof_lof, ν)`` matched to the
        statistic's mean and variance, and ``dof`` reports ``(dof_lof, ν)``.  Referred to
        ``F(dof_lof, dof_pe)`` instead, the test is liberal (``docs/critique.md``).

    Returns
    -------
    LackOfFit or None
        None when no cell is repeated or the cells do not outnumber the parameters, or, with
        ``groups``, when a group has 4 pure-error degrees of freedom or fewer (no variance to match).

    Raises
    ------
    ValueError
        When a residual or a scale is not finite.
    """
    r = np.asarray(residual, dtype=float) / np.asarray(scale, dtype=float)
    if not np.all(np.isfinite(r)):
        raise ValueError("the residuals and their scales must be finite")
    labels, index, counts = np.unique(cells, return_inverse=True, return_counts=True)
    mean = np.bincount(index, weights=r) / counts
    ss_pe = float(np.sum((r - mean[index]) ** 2))
    ss_lof = float(np.sum(counts * mean**2))
    dof_pe = int(r.size - labels.size)
    dof_lof = int(labels.size - n_parameters)
    if dof_pe < 1 or dof_lof < 1 or ss_pe <= 0:
        return None
    statistic = (ss_lof / dof_lof) / (ss_pe / dof_pe)
    if groups is None:
        return LackOfFit(float(statistic), f_survival(dof_lof, dof_pe, statistic), (dof_lof, dof_pe), dof_pe / (dof_pe - 2.0) if dof_pe > 2 else float("inf"))
    matched = _grouped_reference(index, counts, groups, dof_lof)
    if matched is None:
        return None
    factor, dof = matched
    return LackOfFit(float(statistic), f_survival(dof_lof, dof, statistic / factor), (dof_lof, int(round(dof))), factor * dof / (dof - 2.0))


def least_squares_lack_of_fit(
    X: np.ndarray, y: np.ndarray, scale: np.ndarray, cells: np.ndarray, frames: np.ndarray | None = None
) -> LackOfFit | None:
    """The lack-of-fit test of the weighted least-squares fit of ``y`` on ``X``, each reading's direction weighted by its pure error.

    A laser tracker reads distances better than angles: its noise is an ellipsoid
    about the line of sight (the distance meter's error a third of the angles' at
    a few metres), which a distance law of one sd per point does not describe.  In
    base axes the coordinates of a reading are then correlated and unequal, and the
    F statistic spreads wider than its distribution (measured on the independent
    generator's campaign seeded 9002, without an effect: F = 1.29, p = 0.008 with its
    anisotropic noise, called a misfit; F = 1.17, p = 0.07 with isotropic noise of the
    same mean; F = 1.19, p = 0.049 weighted as here).  The equations are therefore
    turned into each reading's ``frames`` and each direction weighted by its own
    variance, estimated from the repeats' scatter alone: no model enters the weights,
    and an isotropic tracker keeps equal ones.

    Parameters
    ----------
    X
        ``(3 N, p)`` the design, three equations per reading (its coordinates in base axes).
    y
        ``(3 N,)`` the observations (m).
    scale
        ``(3 N,)`` the noise model's sd of each equation, up to a common factor.
    cells
        ``(3 N,)`` :func:`replicate_cells` of the readings.
    frames
        ``(N, 3, 3)`` each reading's directions (:func:`line_of_sight`); None: the base axes.

    Returns
    -------
    LackOfFit or None
        As :func:`lack_of_fit`, with the independent columns of ``X`` as its parameters.
    """
    if np.unique(cells).size == cells.size:
        return None  # no repeats, no pure error: nothing to fit
    n = y.size // 3
    if frames is not None:
        y = np.einsum("nij,nj->ni", frames, y.reshape(n, 3)).reshape(-1)
        X = np.einsum("nij,njp->nip", frames, X.reshape(n, 3, -1)).reshape(3 * n, -1)
    direction = np.tile(np.arange(3), n)
    scale = group_scales(y, scale, cells, direction)
    columns = independent_columns(X)
    beta = np.linalg.lstsq(X[:, columns] / scale[:, None], y / scale, rcond=None)[0]
    return lack_of_fit(y - X[:, columns] @ beta, scale, cells, columns.size, groups=direction)


def line_of_sight(position: np.ndarray, tracker: np.ndarray) -> np.ndarray:
    """``(N, 3, 3)`` per reading at ``position`` ``(N, 3)`` (m) the unit vectors along the line of sight from
    ``tracker`` ``(3,)``, across it horizontally, and across it upward."""
    radial = position - tracker
    radial = radial / np.linalg.norm(radial, axis=1, keepdims=True)
    across = np.cross(radial, np.array([0.0, 0.0, 1.0]))
    # a line of sight straight up or down has no horizontal normal: any normal serves
    across = np.where(np.linalg.norm(across, axis=1, keepdims=True) > 1e-6, across, np.cross(radial, np.array([1.0, 0.0, 0.0])))
    across = across / np.linalg.norm(across, axis=1, keepdims=True)
    return np.stack([radial, across, np.cross(across, radial)], axis=1)


def _grouped_reference(index: np.ndarray, counts: np.ndarray, groups: np.ndarray, dof_lof: int) -> tuple[float, float] | None:
    """``(c, ν)``: ``c·F(dof_lof, ν)`` with the mean and variance of a statistic weighted by :func:`group_scales`.

    The statistic is ``Σ_g X_g / dof_lof``, ``X_g = χ²(a_g) / (χ²(b_g) / b_g)`` independent, ``b_g`` the
    group's pure-error dof and ``a_g`` its share of ``dof_lof`` (in proportion to its cells).
    """
    _, group = np.unique(groups, return_inverse=True)
    cells = np.bincount(group, weights=1.0 / counts[index])
    a = dof_lof * cells / cells.sum()
    b = np.bincount(group, weights=(counts[index] - 1.0) / counts[index])
    if np.any(b <= 4):
        return None
    mean = float(np.sum(a * b / (b - 2.0))) / dof_lof
    second = (a**2 + 2.0 * a) * b**2 / ((b - 2.0) * (b - 4.0)) - (a * b / (b - 2.0)) ** 2
    cv2 = float(np.sum(second)) / dof_lof**2 / mean**2
    # an F(d1, ν) has cv² = 2 (d1 + ν - 2) / (d1 (ν - 4)): solved for ν
    if dof_lof * cv2 <= 2.0:
        return None
    dof = (2.0 * dof_lof - 4.0 + 4.0 * dof_lof * cv2) / (dof_lof * cv2 - 2.0)
    return mean * (dof - 2.0) / dof, dof


def f_survival(d1: float, d2: float, f: float) -> float:
    """``P(F > f)`` for an F distribution of ``d1`` and ``d2`` degrees of freedom.

    ``I_x(d2/2, d1/2)`` at ``x = d2 / (d2 + d1 f)``, the regularized incomplete beta
    function, with the standard library only: ``scipy.special`` would add about
    0.3 s to ``bayescal calibrate``'s start (measured with ``python -X importtime``).
    """
    if f <= 0:
        return 1.0
    return _regularized_beta(d2 / (d2 + d1 * f), d2 / 2.0, d1 / 2.0)


_BETA_TERMS = 100_000
"""Most continued-fraction terms: the fraction settles in about ``sqrt(max(a, b))`` terms, a few hundred
for the degrees of freedom of a campaign of 100,000 configurations."""


def _regularized_beta(x: float, a: float, b: float) -> float:
    """``I_x(a, b)``, from the continued fraction of DLMF 8.17.22 on the side of ``x`` where it converges quickly.

    The fraction is evaluated by the modified Lentz method; beyond ``x = (a + 1) / (a + b + 2)``
    the symmetry ``I_x(a, b) = 1 - I_{1-x}(b, a)`` is used instead.
    """
    if x <= 0.0 or x >= 1.0:
        return float(x >= 1.0)
    if x > (a + 1.0) / (a + b + 2.0):
        return 1.0 - _regularized_beta(1.0 - x, b, a)
    log_front = a * math.log(x) + b * math.log1p(-x) - math.log(a) - (math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b))
    tiny = 1e-300
    # Modified Lentz: the fraction 1 / (1 + d1 / (1 + d2 / (1 + ...))).
    first = 1.0 - (a + b) * x / (a + 1.0)
    c, d = 1.0, 1.0 / (first if abs(first) > tiny else tiny)
    value = d
    for m in range(1, _BETA_TERMS):
        for term in (m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)), -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))):
            d = 1.0 + term * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + term / c
            c = c if abs(c) > tiny else tiny
            value *= c * d
        if abs(c * d - 1.0) < 1e-15:
            break
    return math.exp(log_front) * value
