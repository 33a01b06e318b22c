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


def test_extensions_find_nothing_in_a_world_without_their_effects(justin):
    """The independent generator's world has a rigid base and no coupled compliance: the extensions' parameters come
    out within 3 sds of zero (measured: within 1.2) and the held-out predictions are the full model's."""
    rng = np.random.default_rng(11)
    world = independent.draw_world(rng)
    joints = independent.configurations(rng, 260)
    xyz = independent.marker_positions(world, joints, noise_rng=rng)
    train, test = np.arange(200), np.arange(200, 260)
    errors = {}
    for rung in ("full", "coupled-elastic"):
        results = KinematicCalibration(justin, rung).fit(_positions(joints[train], xyz[train]))
        errors[rung] = np.linalg.norm(xyz[test] - results.predict(joints[test])[0], axis=-1).mean()
    added = np.array([p.group in ("k_base", "k_coupled") for p in results.model.parameters])
    assert added.sum() == 11
    assert np.all(np.abs(results.mean[added] / results.sd[added]) < 3)
    assert abs(errors["coupled-elastic"] / errors["full"] - 1) < 0.01


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


def test_the_ladder_leaves_out_an_extension_that_adds_nothing(justin):
    """Without a coupling law there is no mutual compliance to add: ``coupled-elastic`` is not fitted."""
    from dataclasses import replace

    from bayescal.kinematics.ladder import ModelLadder

    coupling = justin.coupling.copy()
    coupling[justin.tree.idx_q[justin.tree.names.index("torso4_joint")]] = 0.0
    rungs = ("full", "base-elastic", "coupled-elastic")
    assert ModelLadder(justin, rungs=rungs)._rungs() == rungs
    assert ModelLadder(replace(justin, coupling=coupling), rungs=rungs)._rungs() == rungs[:2]
