"""The calibration on data it can be checked against: its own model with known parameters, and the independent generator."""

import numpy as np
from scipy import stats

from bayescal.kinematics import KinematicCalibration, Positions
from bayescal.twin.independent import points as independent

from .conftest import simulated


def _positions(joints, xyz):
    n, m = xyz.shape[:2]
    return Positions(joints=joints, xyz=xyz, lines=np.zeros((n, m), int), rows=np.arange(n * m).reshape(n, m))


def test_identified_parameters_cover_their_truth(justin):
    """Over three simulated campaigns, the identified parameters' ±1/2/3σ intervals cover at about the nominal rates."""
    z = []
    for seed in range(3):
        model, truth, joints, xyz = simulated(justin, "geometry", np.random.default_rng(seed), 150)
        results = KinematicCalibration(justin, "geometry").fit(_positions(joints, xyz))
        identified = results.sd / model.sd < 0.5
        z.append(((results.mean - truth) / results.sd)[identified])
    z = np.abs(np.concatenate(z))
    assert len(z) > 100
    for k, nominal in ((1, 0.683), (2, 0.954), (3, 0.997)):
        assert abs(np.mean(z < k) - nominal) < 4 * np.sqrt(nominal * (1 - nominal) / len(z)) + 0.01


def test_independent_generator_held_out_coverage(justin):
    """On a world the method was not built from, the full model's 95 % predictive ellipsoids cover held-out markers."""
    rng = np.random.default_rng(11)
    world = independent.draw_world(rng)
    joints = independent.configurations(rng, 260)
    xyz = independent.marker_positions(world, joints, noise_rng=rng)
    train, test = np.arange(200), np.arange(200, 260)
    results = KinematicCalibration(justin, "full").fit(_positions(joints[train], xyz[train]))
    mean, covariance = results.predict(joints[test])
    residual = xyz[test] - mean
    distance = np.einsum("nma,nmab,nmb->nm", residual, np.linalg.inv(covariance), residual)
    coverage = np.mean(distance <= stats.chi2.ppf(0.95, 3))
    assert 0.85 <= coverage <= 1.0
    assert np.linalg.norm(residual, axis=-1).mean() < 1e-3


def test_the_ladder_names_the_steps_an_independent_world_calls_for(justin):
    """On the independent generator's world (its own DH errors and self-weight elasticity), held out in 3 folds:
    each rung up to the joint-elastic one predicts better, the step is named, and the findings render as JSON."""
    import json

    from bayescal.kinematics.ladder import LADDER_KIND, ModelLadder

    rng = np.random.default_rng(5)
    world = independent.draw_world(rng)
    joints = independent.configurations(rng, 90)
    xyz = independent.marker_positions(world, joints, noise_rng=rng)
    findings = ModelLadder(justin, folds=3, rungs=("frames", "geometry"), leave_out=False).run(_positions(joints, xyz))
    rungs = findings.rungs
    assert rungs.loc["geometry", "mean_mm"] < rungs.loc["frames", "mean_mm"]
    assert findings.steps[0]["named"] and findings.steps[0]["elpd_gain"] > 2 * findings.steps[0]["elpd_gain_se"]
    payload = json.loads(json.dumps(findings.to_json()))
    assert payload["kind"] == LADDER_KIND and payload["published"]["rungs_mean_sd_max_mm"]["full"] == [3.12, 1.71, 8.23]
