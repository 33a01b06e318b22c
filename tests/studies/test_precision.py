"""Tests of bayescal.studies.precision: the eq-37 precision of a plan and the detectability of planted effects."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bayescal.reference import published
from bayescal.studies.precision import design_precision, effect_detectability
from bayescal.twin.effects import parse_effect


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
