import numpy as np
import pytest

from bayescal.identifiability import analyse

DEG = np.pi / 180


def columns(m):
    return [(0, None)] + [(1, a) for a in range(m)] + [(j, None) for j in range(2, 6)]


def design_with(rng, m, n=90):
    X = rng.normal(size=(n, 5 + m))
    angle = np.arange(n) % m
    for a in range(m):
        X[angle != a, 1 + a] = 0.0
    return X, angle


def test_full_rank_design_is_identifiable_with_small_inflation():
    rng = np.random.default_rng(0)
    X, _ = design_with(rng, 5)
    torque = np.ones((5, 6))
    result = analyse(X, columns(5), np.linspace(-2, 0, 5), torque, np.arange(5))
    assert result.rank == X.shape[1]
    assert result.identifiable.all()
    assert result.compensator
    assert result.reasons == {}
    assert 1 <= result.condition_number < 10
    assert all(1 <= v < 2 for v in result.vif.values())


def test_joint_without_torque_is_reported_with_the_reason_from_the_data():
    rng = np.random.default_rng(1)
    X, _ = design_with(rng, 5)
    X[:, 0] = 0.0
    torque = np.ones((5, 6))
    torque[:, 0] = 0.0
    result = analyse(X, columns(5), np.linspace(-2, 0, 5), torque, np.arange(5))
    assert not result.identifiable[0]
    assert "torque about the axis of joint 1" in result.reasons["k1"]
    assert result.identifiable[1:].all()
    assert result.to_json()["not_identifiable"].keys() == {"k1"}


def test_collinear_columns_are_confounded():
    rng = np.random.default_rng(2)
    X, _ = design_with(rng, 5)
    X[:, 6] = 2.0 * X[:, 7]
    result = analyse(X, columns(5), np.linspace(-2, 0, 5), np.ones((5, 6)), np.arange(5))
    assert result.rank == X.shape[1] - 1
    assert not result.identifiable[6] and not result.identifiable[7]
    assert "k4" in result.reasons["k3"]


@pytest.mark.parametrize("m", [1, 2])
def test_compensator_needs_three_angles(m):
    rng = np.random.default_rng(3)
    X, _ = design_with(rng, m)
    result = analyse(X, columns(m), np.array([-10.0, -50.0][:m]) * DEG, np.ones((m, 6)), np.arange(m))
    assert not result.compensator
    for name in ("k2", "K_c", "s0"):
        assert f"{m} q2 angle(s)" in result.reasons[name]
    assert result.identifiable.all()
