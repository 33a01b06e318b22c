import dataclasses

import numpy as np
import pandas as pd
import pytest

from bayescal.inference.identifiability import analyse, angle_label, independent_columns, label_angle, practical_reasons

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


def summary(rows):
    frame = pd.DataFrame.from_dict(
        {name: {"mean": m, "sd": s, "lo3": m - 3 * s, "hi3": m + 3 * s, "unit": u} for name, (m, s, u) in rows.items()},
        orient="index",
    )
    return frame


def test_flat_prior_parameter_fails_when_its_interval_reaches_zero():
    frame = summary({"K_c": (876.0, 518.0, "N/mm"), "k3": (0.406, 0.0027, "urad/(N m)"), "k6": (2.0, 0.67, "urad/(N m)")})
    reasons = practical_reasons(frame, {"K_c": None, "k3": None, "k6": None})
    assert set(reasons) == {"K_c", "k6"}
    assert "[-678, 2430] N/mm includes 0" in reasons["K_c"]
    assert "177 %" in reasons["K_c"]
    # 3 sd = 100.5 % of the mean: just past the boundary.
    assert "includes 0" in reasons["k6"]


def test_proper_prior_parameter_fails_when_the_posterior_barely_contracts():
    frame = summary({"a": (1.0, 0.6, "mm"), "b": (1.0, 0.4, "mm")})
    reasons = practical_reasons(frame, {"a": 1.0, "b": 1.0})
    assert list(reasons) == ["a"]
    assert "0.60 of its prior's 1 mm" in reasons["a"]


def test_dependent_parameter_follows_the_one_it_enters_through():
    frame = summary({"K_c": (876.0, 518.0, "N/mm"), "s0": (482.0, 107.0, "mm")})
    reasons = practical_reasons(
        frame, {"K_c": None, "s0": 254.0}, requires={"s0": "K_c"}, context={"K_c": "the compensator is weak"}
    )
    assert reasons["K_c"].startswith("the compensator is weak; its ±3σ interval")
    assert "only through the product s0·K_c" in reasons["s0"]
    identified = summary({"K_c": (153.6, 5.1, "N/mm"), "s0": (460.0, 3.5, "mm")})
    assert practical_reasons(identified, {"K_c": None, "s0": 254.0}, requires={"s0": "K_c"}) == {}


def test_practical_reasons_join_the_structural_ones_in_the_report():
    rng = np.random.default_rng(0)
    X, _ = design_with(rng, 5)
    X[:, 0] = 0.0
    torque = np.ones((5, 6))
    torque[:, 0] = 0.0
    result = analyse(X, columns(5), np.linspace(-2, 0, 5), torque, np.arange(5))
    result = dataclasses.replace(result, practical={"K_c": "weak"})
    block = result.to_json()
    assert list(block["not_identifiable"]) == ["k1", "K_c"]
    assert block["structural"] == ["k1"]


def test_each_confounded_parameter_names_only_its_own_partners():
    rng = np.random.default_rng(4)
    X, _ = design_with(rng, 5)
    X[:, 6] = X[:, 7]  # k3 and k4 move together
    X[:, 8] = 2.0 * X[:, 9]  # and, separately, k5 and k6
    result = analyse(X, columns(5), np.linspace(-2, 0, 5), np.ones((5, 6)), np.arange(5))
    assert "combination of k3 with k4:" in result.reasons["k3"]
    assert "combination of k5 with k6:" in result.reasons["k5"]
    assert result.identifiable[:6].all()


def test_per_angle_names_are_read_back_to_their_angle():
    name = angle_label(np.radians(-25.24))
    assert name == "k2_q2[-25.240]"
    assert label_angle(name) == pytest.approx(-25.24)
    assert label_angle(angle_label(-1e-4)) == pytest.approx(-0.006)
    for other in ("k2", "K_c", "s0", "k2_q2", "sigma[P1]"):
        assert label_angle(other) is None


def test_a_tall_confounded_design_is_analysed_without_its_full_left_basis():
    # 200,000 rows: a full U would be 200,000 × 200,000 (320 GB).
    rng = np.random.default_rng(0)
    design = rng.normal(size=(200_000, 4))
    design[:, 3] = design[:, 1] + design[:, 2]
    result = analyse(design, [(0, None), (1, None), (2, None), (3, None)], np.zeros(0), np.ones((10, 4)), np.zeros(10, int))
    assert list(result.identifiable) == [True, False, False, False]
    assert "k3, k4" in result.reasons["k2"]


def test_independent_columns_drops_combinations_of_earlier_columns():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(30, 3))
    X = np.column_stack([X, np.zeros(30), X[:, 0] - 2 * X[:, 2], rng.normal(size=30)])
    assert independent_columns(X).tolist() == [0, 1, 2, 5]
