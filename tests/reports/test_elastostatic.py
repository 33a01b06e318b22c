import warnings

import numpy as np
import pytest
from scipy import stats

from bayescal.sampling.gibbs import GibbsSampler
from bayescal.inference.elastostatic import ElastostaticModel
from bayescal.reports.elastostatic import compensator_precision, linearisation_misfit, weightless
from bayescal.studies.precision import design_precision
from bayescal.twin.simulator import DigitalTwin
from bayescal.units import UM


def test_linear_model_misfit_at_8_um_is_the_linearisation(cell, plan):
    full = linearisation_misfit(cell, plan, 8 * UM, seed=0)
    assert full["n_equations"] == 405 and full["dof"] == 396
    dof = full["dof"]
    low, high = stats.chi2.ppf([0.001, 0.999], dof) / dof
    # Noise alone would exceed `high` once in a thousand campaigns; the exact model fits like noise.
    assert full["linear"] > high
    assert low < full["exact"] < high
    assert full["linear"] - full["exact"] > 0.15
    # Loads and noise / 10: the second-order part of the misfit goes; what is left is within chi-square noise.
    small = linearisation_misfit(cell, plan, 0.8 * UM, load_scale=0.1, seed=0)
    assert low < small["linear"] < high
    assert small["linear"] - small["exact"] < 0.1
    # Same noise draws, scaled with the deflections: the exact model is exact at both scales.
    assert small["exact"] == pytest.approx(full["exact"], rel=2e-3)


def test_without_the_arms_weight_the_misfit_is_purely_second_order(cell, plan):
    bare = weightless(cell)
    assert np.allclose(bare.robot.gravity_torque(plan.q[0]), 0.0)
    full = linearisation_misfit(bare, plan, 8 * UM, seed=0)
    small = linearisation_misfit(bare, plan, 0.8 * UM, load_scale=0.1, seed=0)
    excess_full = (full["linear"] - full["exact"]) * full["dof"]
    excess_small = (small["linear"] - small["exact"]) * small["dof"]
    assert excess_full > 50
    assert abs(excess_small) < 0.05 * excess_full


def test_compensator_precision_agrees_with_eq_37_and_names_the_gap_to_table_iv(cell, plan):
    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=2, n_tune=50, n_draws=100)).fit(campaign, 1)
    precision = compensator_precision(results, cell)
    eq37 = design_precision(cell, plan)
    for name in ("K_c", "s0"):
        assert precision["width_pct"][name] == pytest.approx(eq37.loc[name, "width_3sd_pct"], rel=0.25), name
    # Table IV's compensator widths are out of this campaign's reach by more than an order of magnitude.
    assert precision["needed_factor"]["K_c"] > 10 and precision["needed_factor"]["s0"] > 10
    low, high = precision["share_pct"]
    assert 0.03 < low < high < 0.3
    assert precision["needed_per_angle_3sd_pct"] < high < precision["per_angle_3sd_pct"]
