"""Tests of bayescal_studies.studies.balance: the compensator against the arm's weight about joint 2."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bayescal_studies.studies.balance import gravity_balance, spring_balance
from bayescal.units import DEG, MM


def test_gravity_balance_sets_the_spring_against_the_weight(cell):
    table = gravity_balance(cell, [0.0, -25.24, -140.0])
    assert list(table.index) == [0.0, -25.24, -140.0]
    q = np.zeros(cell.robot.nq)
    q[cell.compensated_joint], q[cell.compensated_joint + 1] = -25.24 * DEG, 25.24 * DEG
    row = table.loc[-25.24]
    assert row["weight_torque_Nm"] == pytest.approx(cell.robot.gravity_torque(q)[cell.compensated_joint])
    assert row["compensator_torque_Nm"] == pytest.approx(-cell.compensator.torque(-25.24 * DEG))
    assert row["residual_torque_Nm"] == pytest.approx(row["weight_torque_Nm"] - row["compensator_torque_Nm"])
    assert row["spring_length_mm"] == pytest.approx(cell.compensator.s(-25.24 * DEG) / MM)
    # eq 8: the spring adds a fraction of a percent to the joint-2 stiffness
    assert (table["compensator_share_pct"] > 0).all() and (table["compensator_share_pct"] < 1).all()


def test_the_best_free_length_minimises_the_torque_left_to_the_drive(cell):
    best = spring_balance(cell, [1.0]).loc[1.0]
    assert best["residual_rms_Nm"] < best["weight_max_Nm"] / 2
    for shift in (-5.0, 5.0):
        spring = cell.compensator.geometry.with_spring(cell.compensator.K_c, (best["free_length_mm"] + shift) * MM)
        other = dataclasses.replace(cell, compensator=spring)
        # a spring with another free length, refitted, comes back to the same optimum
        assert spring_balance(other, [1.0]).loc[1.0, "free_length_mm"] == pytest.approx(best["free_length_mm"])
        table = gravity_balance(other, np.linspace(-140.0, 0.0, 57))
        assert np.sqrt(np.mean(table["residual_torque_Nm"] ** 2)) > best["residual_rms_Nm"]


def test_a_much_stiffer_spring_cannot_balance_the_arm(cell):
    table = spring_balance(cell, [1.0, 10.0])
    assert table.loc[10.0, "residual_rms_Nm"] > table.loc[10.0, "weight_max_Nm"] > table.loc[1.0, "residual_rms_Nm"]
    with pytest.raises(ValueError, match="positive"):
        spring_balance(cell, [0.0])
