import numpy as np
import pytest

from bayescal.kinematics import PointModel
from bayescal.kinematics.model import EXTENSIONS, RUNGS


@pytest.mark.parametrize(("rung", "omitted"), [("geometry", 0.1), ("full", 0.1), ("coupled-elastic", 0.2)])
def test_jacobian_matches_finite_differences(justin, rung, omitted):
    model = PointModel(justin, rung)
    rng = np.random.default_rng(1)
    theta = model.mean + 0.3 * model.sd * rng.standard_normal(model.size)
    # Compliances of a real arm's size (Justin's come out at tens of μrad/(N·m)), the base's shift of tens of μm/(N·m):
    # deflections of mm.
    elastic = np.array([p.group in ("k_theta", "k_alpha", "k_coupled", "k_base") for p in model.parameters])
    theta[elastic] = 50e-6 * rng.standard_normal(elastic.sum())
    q = justin.model_configuration(rng.uniform(-1.5, 1.5, size=(3, 19)))
    _, jacobian = model.predict(theta, q)
    step = 1e-6 * np.maximum(model.sd, 1e-3)
    numeric = np.empty_like(jacobian)
    for i in range(model.size):
        up, _ = model.predict(theta + np.eye(model.size)[i] * step[i], q, jacobian=False)
        down, _ = model.predict(theta - np.eye(model.size)[i] * step[i], q, jacobian=False)
        numeric[..., i] = (up - down) / (2 * step[i])
    scale = np.abs(numeric).max(axis=(0, 1, 2)) + 1e-12
    relative = np.abs(jacobian - numeric).max(axis=(0, 1, 2)) / scale
    # Exact for the elastic parameters and the masses; for the kinematic ones the deflection's own change is left out
    # (a Gauss-Newton approximation of the order of the deflection over the arm's length).
    exact = elastic | np.array([p.group == "masses" for p in model.parameters])
    assert np.all(relative[exact] < 1e-4), relative[exact].max()
    # Measured on this draw: 0.08 of a column in the full model; 0.15 with the coupled torso compliances, whose torques
    # (up to 190 N·m on Justin) change with a shift of the torso along its axis.
    assert relative.max() < omitted


def test_rungs_nest_and_groups_leave_out(justin):
    sizes = [PointModel(justin, rung).size for rung in RUNGS + EXTENSIONS]
    assert sizes == sorted(sizes) and len(set(sizes)) == len(sizes)
    full = PointModel(justin, "full")
    without = PointModel(justin, "full", without=("k_alpha",))
    assert not any(p.group == "k_alpha" for p in without.parameters)
    assert without.size == PointModel(justin, "joint-elastic").size < full.size


def test_extensions_add_the_base_and_the_coupled_torso_compliances(justin):
    """The base yields by 2 × 2 turns and shifts; the coupling law q4 = -(q2 + q3) ties torso joints 2, 3, 4 pairwise."""
    full, base, coupled = (PointModel(justin, rung) for rung in ("full", "base-elastic", "coupled-elastic"))
    assert [p.name for p in base.parameters if p.group == "k_base"] == [
        f"base.{kind}_{a}_per_M{b}" for kind in ("turn", "shift") for a in "xy" for b in "xy"]
    assert [p.name for p in coupled.parameters if p.group == "k_coupled"] == [
        "torso2_joint.k_theta.torso3_joint", "torso2_joint.k_theta.torso4_joint", "torso3_joint.k_theta.torso4_joint"]
    assert base.size == full.size + 8 and coupled.size == base.size + 3
    # With the new compliances at zero, the extensions predict what the full model does.
    q = justin.model_configuration(np.random.default_rng(2).uniform(-1.5, 1.5, size=(4, 19)))
    theta = full.mean + 0.1 * full.sd * np.random.default_rng(3).standard_normal(full.size)
    extended = dict(zip(full.names, theta))
    padded = np.array([extended.get(name, 0.0) for name in coupled.names])
    assert np.allclose(coupled.predict(padded, q, jacobian=False)[0], full.predict(theta, q, jacobian=False)[0], atol=1e-12)
