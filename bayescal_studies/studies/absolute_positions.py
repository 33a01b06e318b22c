"""Absolute positions of a KR-270 with kinematic errors: held-out accuracy and the coverage of the identified geometry.

For each simulated world (:mod:`bayescal_studies.studies.kinematic_worlds`: the twin or the
independent generator, kinematic errors of realistic size) the elastostatic
calibration (``calibrate``: loaded minus unloaded, nominal geometry) gives the
arm's deflection model, and the geometry rung of the kinematic calibration,
with that model's spring and masses refined (:mod:`bayescal.kinematics.elastic`),
is fitted to the calibration campaign's unloaded readings (one repeat).

:func:`absolute_accuracy` predicts the held-out configurations, unloaded and
loaded, with the identified geometry and with the nominal one (plus the
elastostatic medians' deflection): residuals over the tracker's sd per
coordinate, the 95 % predictive ellipsoids' coverage, the mean distance.

:func:`kinematic_coverage` compares the posterior with the world's truth where the
data, not the priors, decide: along the posterior's well-determined directions
(the data's information, in prior-whitened coordinates, at least
:data:`DETERMINED_GAIN` times the prior's) and for each parameter the data
identify (posterior sd below :data:`IDENTIFIED_SD_RATIO` of its prior's).  The
base, the first joint's placement and the markers share their effects (any one
of them moves the whole arm or the whole tool), so most single parameters are set
by the priors and only such combinations can be checked.
"""

from __future__ import annotations

import warnings
from concurrent.futures import Executor

import numpy as np
import pandas as pd

from bayescal.cell.config import Cell
from bayescal.compensation.calibration import calibration_from_tree
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.elastic import ArmDeflection, ElasticKinematicCalibration, ElasticKinematicResults
from bayescal.kinematics.from_campaign import campaign_positions
from bayescal.kinematics.model import PointModel
from bayescal_studies.studies.kinematic_worlds import KinematicWorld, simulate_world
from bayescal.design.parallel import seeded_map

__all__ = ["absolute_accuracy", "coverage_table", "kinematic_coverage", "posterior_checks", "predictive_scores", "DETERMINED_GAIN",
           "IDENTIFIED_SD_RATIO"]

CHI2_3_95 = 7.814727903251178
"""The 95 % quantile of χ² with 3 degrees of freedom: a marker's 95 % predictive ellipsoid."""

DETERMINED_GAIN = 100.0
"""A direction is well determined when the data's information along it is this many times the prior's: the prior
then pulls its estimate by 1/101 of the truth's distance from the prior mean, 0.1 posterior sd for a truth 1 prior sd off."""

IDENTIFIED_SD_RATIO = 0.1
"""A single parameter is checked when its posterior sd is below this fraction of its prior sd (the same pull, 1 %)."""


def predictive_scores(observed: np.ndarray, mean: np.ndarray, covariance: np.ndarray, tracker_sd: np.ndarray) -> dict:
    """Held-out scores of ``(N, M, 3)`` observed against predicted positions with ``(N, M, 3, 3)`` covariances.

    Returns ``rms_over_noise`` (the residuals' rms over the tracker's sd ``(N, M)`` per coordinate),
    ``coverage_95`` (of the predictive ellipsoids) and ``mean_error_mm`` (the mean distance).
    """
    residual = observed - mean
    distance = np.einsum("nma,nma->nm", residual, np.linalg.solve(covariance, residual[..., None])[..., 0])
    return {"rms_over_noise": float(np.sqrt(np.mean((residual / tracker_sd[..., None]) ** 2))),
            "coverage_95": float(np.mean(distance <= CHI2_3_95)),
            "mean_error_mm": float(np.linalg.norm(residual, axis=-1).mean() * 1e3)}


def _calibrate(cell: Cell, points: PointsCell, world: KinematicWorld, rng: np.random.Generator):
    """The elastostatic calibration of the world's campaign, then the kinematic one on its unloaded readings."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        elastic = ElastostaticModel.from_cell(cell).fit(world.campaign, rng)
    calibration = calibration_from_tree(elastic.tree, cell)
    positions, *_ = campaign_positions(world.campaign, points)
    return calibration, ElasticKinematicCalibration.from_calibration(cell, points, calibration).fit(positions)


def absolute_accuracy(cell: Cell, points: PointsCell, seed: int, *, generator: str = "twin", scale: float = 1.0,
                      size: tuple[int, int, int] = (6, 10, 3), held_out: tuple[int, int] = (6, 5)) -> pd.DataFrame:
    """One simulated world's held-out absolute accuracy, identified and nominal geometry, unloaded and loaded.

    Parameters are those of :func:`~bayescal_studies.studies.kinematic_worlds.simulate_world`, ``seed`` the root of its draws.

    Returns
    -------
    pandas.DataFrame
        One row per geometry (``identified``, ``nominal``) and state (``unloaded``, ``loaded``): the scores of
        :func:`predictive_scores`, the learned model error ``model_sd_um`` and the ``seed``.
    """
    rng = np.random.default_rng(seed)
    world = simulate_world(cell, points, rng, generator=generator, scale=scale, size=size, held_out=held_out)
    calibration, fit = _calibrate(cell, points, world, rng)
    deflection = ArmDeflection.from_calibration(cell, points, calibration)
    nominal = PointModel(points, "geometry")
    rows = []
    for state in ("unloaded", "loaded"):
        observed, wrenches, load_points = campaign_positions(world.held_out, points, loaded=state == "loaded")
        load = wrenches if state == "loaded" else None
        sd = points.tracker.sigma(observed.xyz)
        mean, covariance = fit.predict(observed.joints, load, load_points)
        rows.append({"geometry": "identified", "state": state} | predictive_scores(observed.xyz, mean, covariance, sd))
        rigid, _ = nominal.predict(nominal.mean, points.model_configuration(observed.joints), jacobian=False)
        noise = (sd**2)[..., None, None] * np.eye(3)
        rows.append({"geometry": "nominal", "state": state}
                    | predictive_scores(observed.xyz, rigid + deflection(observed.joints, load, load_points), noise, sd))
    return pd.DataFrame(rows).assign(model_sd_um=fit.kinematic.model_sd * 1e6, seed=seed)


def kinematic_coverage(cell: Cell, points: PointsCell, campaigns: int, seed: int, *, generator: str = "twin", scale: float = 1.0,
                       size: tuple[int, int, int] = (6, 10, 3), executor: Executor | None = None,
                       progress: str | None = None) -> pd.DataFrame:
    """Truth against posterior along the well-determined directions and for the identified parameters.

    Returns
    -------
    pandas.DataFrame
        One row per campaign and check: ``campaign``, ``kind`` (``direction`` or ``parameter``), ``name`` (the
        parameter, or the direction's rank), ``gain`` (data over prior information along it; for a parameter,
        prior over posterior variance), ``z`` = (truth - mean) / sd.
    """
    rows = seeded_map(_coverage_campaign, range(campaigns), seed, executor=executor, progress=progress, cell=cell, points=points,
                      generator=generator, scale=scale, size=size)
    return pd.DataFrame([row for campaign in rows for row in campaign])


def _coverage_campaign(index: int, rng: np.random.Generator, *, cell, points, generator, scale, size) -> list[dict]:
    world = simulate_world(cell, points, rng, generator=generator, scale=scale, size=size, held_out=(1, 1))
    _, fit = _calibrate(cell, points, world, rng)
    return [{"campaign": index} | row for row in posterior_checks(fit, world.truth)]


def posterior_checks(fit: ElasticKinematicResults, truth: dict[str, float]) -> list[dict]:
    """The z-scores of :func:`kinematic_coverage` for one fit and its world's ``truth`` (SI, by parameter name)."""
    results = fit.kinematic
    model = results.model
    true = np.array([truth[name] for name in model.names])
    error = true - results.mean
    rows = [{"kind": "parameter", "name": name, "gain": float((prior / sd) ** 2), "z": float(e / sd)}
            for name, prior, sd, e in zip(model.names, model.sd, results.sd, error) if sd < IDENTIFIED_SD_RATIO * prior]
    # Directions of the data's information in prior-whitened coordinates: u^T (S I S) u = gain, S = diag(prior sd).
    whitened = results.covariance / np.outer(model.sd, model.sd)
    values, vectors = np.linalg.eigh(whitened)
    for rank, (value, u) in enumerate(zip(values, vectors.T)):
        gain = 1.0 / value - 1.0
        if gain < DETERMINED_GAIN:
            break
        rows.append({"kind": "direction", "name": str(rank), "gain": float(gain), "z": float(u @ (error / model.sd) / np.sqrt(value))})
    return rows


def coverage_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per kind of check: the number of checks and the share within ±1, 2, 3 sd (nominal 68.3, 95.4, 99.7 %)."""
    return rows.groupby("kind").apply(lambda g: pd.Series({
        "checks": len(g), **{f"within_{k}sd": float(np.mean(np.abs(g.z) <= k)) for k in (1, 2, 3)}}), include_groups=False)
