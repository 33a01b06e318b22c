"""Tests of bayescal_studies.studies.precision: eq-37 precision, effect detectability, and the compensator's precision."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from bayescal.reference import published
from bayescal_studies.studies.precision import (
    compensator_precision,
    design_precision,
    effect_detectability,
    table_iv_width_ratio,
)
from bayescal.twin.effects import parse_effect


@pytest.fixture(scope="module")
def results(short_exact_fit):
    return short_exact_fit


def test_design_precision_is_of_the_order_of_table_iv(cell, plan):
    precision = design_precision(cell, plan, repeats=3)
    assert math.isnan(precision.loc["k1", "sd"])  # no torque on the vertical A1 under vertical loads
    widths = precision["width_3sd_pct"]
    table_iv_width = {name: 100 * half / value for name, (value, half) in published("IV").items()}
    for name in ("k2", "k3", "k4", "k5", "k6"):
        assert table_iv_width[name] / 3 < widths[name] < 3 * table_iv_width[name]
    ratio = np.exp(np.mean(np.log([widths[n] / table_iv_width[n] for n in ("k2", "k3", "k4", "k5", "k6")])))
    assert ratio == pytest.approx(1.0, abs=0.1)
    # the compensator spring is out of reach of the deflections (see docs/twin.md)
    assert widths["K_c"] > 100 and widths["s0"] > 50
    # widths scale with the tracker noise
    quiet = replace(cell, tracker=replace(cell.tracker, factor=cell.tracker.factor / 2))
    np.testing.assert_allclose(design_precision(quiet, plan)["width_3sd_pct"]["k2":"k6"], widths["k2":"k6"] / 2, rtol=1e-9)


def test_detectability_separates_strong_and_weak_effects(cell, plan):
    threshold = np.sqrt(2 * 405)  # the spread of a χ² with 405 degrees of freedom
    linear = effect_detectability(cell, plan, None)
    assert linear["n_equations"] == 405 and linear["noncentrality"] < threshold
    assert effect_detectability(cell, plan, parse_effect("compensator=0"))["noncentrality"] < threshold
    assert effect_detectability(cell, plan, parse_effect("tool_compliance"))["noncentrality"] < threshold
    for name in ("backlash", "nonlinear_stiffness", "link_compliance"):
        result = effect_detectability(cell, plan, parse_effect(name))
        assert result["noncentrality"] > 2 * threshold, name
        assert result["rms_unexplained_um"] < result["rms_difference_um"]


def test_width_ratio_to_table_iv_is_the_geometric_mean_over_the_excited_joints():
    precision = pd.DataFrame(
        {"width_3sd_pct": [np.nan, 2.0, 8.0, 500.0], "table_iv_pct": [np.nan, 1.0, 2.0, 20.0]}, index=["k1", "k2", "k3", "K_c"]
    )
    compared, ratio = table_iv_width_ratio(precision)
    assert compared == ["k2", "k3"]  # k1 not excited, K_c not a joint compliance
    assert ratio == pytest.approx(math.sqrt(2.0 * 4.0))


def test_compensator_precision_agrees_with_eq_37_and_names_the_gap_to_table_iv(cell, plan, results):
    precision = compensator_precision(results, cell)
    eq37 = design_precision(cell, plan)
    spring = precision.spring
    for name in ("K_c", "s0"):
        assert spring.loc[name, "width_3sd_pct"] == pytest.approx(eq37.loc[name, "width_3sd_pct"], rel=0.25), name
        assert spring.loc[name, "table_iv_width_pct"] == pytest.approx(eq37.loc[name, "table_iv_pct"])
    # Table IV's compensator widths are out of this campaign's reach by more than an order of magnitude.
    assert (spring["needed_factor"] > 10).all()
    share = precision.per_angle["compensator_share_pct"]
    assert list(precision.per_angle.index) == pytest.approx(list(np.degrees(results.compensated_angles)))
    assert 0.03 < share.min() < share.max() < 0.3
    assert precision.needed_per_angle_width_pct < share.max() < precision.per_angle["width_3sd_pct"].median()
