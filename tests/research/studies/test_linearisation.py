"""Tests of bayescal_studies.studies.linearisation: the linear model's misfit on nonlinear twin campaigns."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from bayescal_studies.studies.linearisation import linearisation_misfit, linearisation_study, misfit_summary, unloaded_sag, weightless
from bayescal.units import UM


def test_linear_model_misfit_at_8_um_is_the_linearisation(cell, plan):
    full = linearisation_misfit(cell, plan, 8 * UM, seeds=[0]).loc[0]
    assert full["n_equations"] == 405 and full["dof"] == 396
    dof = full["dof"]
    low, high = stats.chi2.ppf([0.001, 0.999], dof) / dof
    # Noise alone would exceed `high` once in a thousand campaigns; the exact model fits like noise.
    assert full["chi2_per_dof_linear"] > high
    assert low < full["chi2_per_dof_exact"] < high
    assert full["chi2_per_dof_linear"] - full["chi2_per_dof_exact"] > 0.15
    # Loads and noise / 10: the second-order part of the misfit goes; what is left is within chi-square noise.
    small = linearisation_misfit(cell, plan, 0.8 * UM, load_scale=0.1, seeds=[0]).loc[0]
    assert low < small["chi2_per_dof_linear"] < high
    assert small["chi2_per_dof_linear"] - small["chi2_per_dof_exact"] < 0.1
    # Same noise draws, scaled with the deflections: the exact model is exact at both scales.
    assert small["chi2_per_dof_exact"] == pytest.approx(full["chi2_per_dof_exact"], rel=2e-3)


def test_without_the_arms_weight_the_misfit_is_purely_second_order(cell, plan):
    bare = weightless(cell)
    assert np.allclose(bare.robot.gravity_torque(plan.q[0]), 0.0)
    assert np.allclose(unloaded_sag(bare, plan).to_numpy(), 0.0)
    full = misfit_summary(linearisation_misfit(bare, plan, 8 * UM, seeds=[0]))
    small = misfit_summary(linearisation_misfit(bare, plan, 0.8 * UM, load_scale=0.1, seeds=[0]))
    assert full["excess_chi2"] > 50
    assert abs(small["excess_chi2"]) < 0.05 * full["excess_chi2"]


def test_misfit_summary_counts_seeds_beyond_the_noise():
    dof = 100
    high = stats.chi2.ppf(0.999, dof) / dof
    runs = pd.DataFrame(
        {
            "chi2_per_dof_linear": [1.0, high + 0.1, 1.2 * high],
            "chi2_per_dof_exact": [0.9, 1.0, 1.1],
            "n_equations": 110,
            "dof": dof,
        }
    )
    summary = misfit_summary(runs)
    assert summary["linear_beyond"] == 2 and summary["exact_beyond"] == 0
    assert summary["noise_high"] == pytest.approx(high)
    assert summary["excess_chi2"] == pytest.approx(np.mean(runs["chi2_per_dof_linear"] - runs["chi2_per_dof_exact"]) * dof)
    assert summary["gap_min"] == pytest.approx(0.1) and summary["n_seeds"] == 3


def test_the_unloaded_twin_sags_under_its_weight(cell, plan):
    sag = unloaded_sag(cell, plan)
    assert len(sag) == len(plan) and list(sag.columns[:2]) == ["sag_j1_mrad", "sag_j2_mrad"]
    # joint 2 carries the arm's weight; joint 1, vertical, carries none of it
    assert sag["sag_j2_mrad"].abs().max() > 0.1
    assert sag["sag_j1_mrad"].abs().max() < 1e-9


def test_the_study_runs_the_four_campaigns(cell, plan):
    study = linearisation_study(cell, plan, seeds=[0])
    assert list(study.index) == [("cell", 1.0), ("cell", 0.1), ("weightless", 1.0), ("weightless", 0.1)]
    assert list(study["noise_um"]) == pytest.approx([8.0, 0.8, 8.0, 0.8])
    assert study["dof"].dtype.kind == "i" and (study["n_equations"] == 405).all()
    alone = misfit_summary(linearisation_misfit(weightless(cell), plan, 0.8 * UM, load_scale=0.1, seeds=[0]))
    assert study.loc[("weightless", 0.1), "excess_chi2"] == pytest.approx(alone["excess_chi2"])
    # the arm's own sag keeps part of the misfit at reduced loads; without weight it goes
    assert study.loc[("cell", 0.1), "excess_chi2"] > 5 * study.loc[("weightless", 0.1), "excess_chi2"]
