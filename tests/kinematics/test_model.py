import numpy as np
import pytest

from bayescal.kinematics import PointModel
from bayescal.kinematics.model import RUNGS


@pytest.mark.parametrize("rung", ["geometry", "full"])
def test_jacobian_matches_finite_differences(justin, rung):
    model = PointModel(justin, rung)
    rng = np.random.default_rng(1)
    theta = model.mean + 0.3 * model.sd * rng.standard_normal(model.size)
    # Compliances of a real arm's size (Justin's come out at tens of μrad/(N·m)): deflections of mm.
    elastic = np.array([p.group in ("k_theta", "k_alpha") for p in model.parameters])
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
    # Exact for the elastic parameters; for the kinematic ones the deflection's own change is left out
    # (a Gauss-Newton approximation of the order of the deflection over the arm's length).
    exact = elastic | np.array([p.group == "masses" for p in model.parameters])
    assert np.all(relative[exact] < 1e-4), relative[exact].max()
    assert relative.max() < 0.1


def test_rungs_nest_and_groups_leave_out(justin):
    sizes = [PointModel(justin, rung).size for rung in RUNGS]
    assert sizes == sorted(sizes) and len(set(sizes)) == len(sizes)
    full = PointModel(justin, "full")
    without = PointModel(justin, "full", without=("k_alpha",))
    assert not any(p.group == "k_alpha" for p in without.parameters)
    assert without.size == PointModel(justin, "joint-elastic").size < full.size
