"""Tests of bayescal_studies.reports.elastostatic: the prose is worded from the findings it is given."""

from __future__ import annotations

import pandas as pd
import pytest

from bayescal_studies.reports.elastostatic import _estimates_table, _linearisation_section
from bayescal_studies.studies.linearisation import REDUCED, linearisation_findings

def summary(linear: float, exact: float, excess: float, gap_min: float, beyond: int) -> pd.Series:
    """A misfit summary over 5 seeds of 405 equations, as studies.linearisation.misfit_summary gives it."""
    return pd.Series(
        {
            "linear_mean": linear,
            "linear_min": linear - 0.02,
            "linear_max": linear + 0.02,
            "exact_mean": exact,
            "exact_min": exact - 0.03,
            "exact_max": exact + 0.03,
            "excess_chi2": excess,
            "gap_min": gap_min,
            "gap_max": gap_min + 0.1,
            "noise_low": 0.79,
            "noise_high": 1.234,
            "linear_beyond": beyond,
            "exact_beyond": 0,
            "n_seeds": 5,
            "n_equations": 405,
            "dof": 396,
        },
        dtype=object,
    )


def section(full: pd.Series, reduced: pd.Series, bare_reduced: pd.Series) -> str:
    """The section for a linearisation study with these summaries (the weightless twin at full load as ``full``)."""
    rows = {("cell", 1.0): full, ("cell", REDUCED): reduced, ("weightless", 1.0): full, ("weightless", REDUCED): bare_reduced}
    study = pd.DataFrame.from_dict(
        {key: pd.concat([row, pd.Series({"noise_um": 8 * key[1]}, dtype=object)]) for key, row in rows.items()}, orient="index"
    )
    study = study.astype(float)
    study.index.names = ["twin", "load_scale"]
    sag = pd.DataFrame({"sag_j1_mrad": [0.0], "sag_j2_mrad": [-0.58], "sag_j3_mrad": [0.33]})
    return "\n".join(_linearisation_section(linearisation_findings(study, sag)))


def test_a_misfit_beyond_the_noise_is_called_the_linearisation():
    text = section(summary(1.25, 0.99, 101.0, 0.21, 3), summary(1.04, 0.99, 17.0, 0.01, 0), summary(0.995, 0.99, 1.3, 0.0, 0))
    assert "misfit is real (excess χ² ≈ 101" in text
    assert "3 of 5 seeds beyond" in text and "dof = 396." in text
    assert "on every seed 0.21–0.31 above" in text
    assert "is that of noise: the misfit is the linearisation" in text
    assert "about 1.26, is lower than the reported 1.3–1.4" in text  # 1 + 101 / 396
    assert "does not fall to the reported 1.02 but keeps an excess χ² of about 17" in text
    assert "a 78-fold drop, near the 100-fold" in text
    assert "up to 0.58 mrad at joint 2 and 0.33 mrad at joint 3" in text
    assert "| the twin | ×1 | 8 | 1.250 (1.230–1.270) | 0.990 (0.960–1.020) | 101.0 |" in text


def test_a_misfit_within_the_noise_is_not_called_real():
    text = section(summary(1.01, 1.0, 4.0, -0.01, 0), summary(1.0, 1.0, 0.5, -0.02, 0), summary(1.0, 1.0, 2.0, -0.02, 0))
    assert "misfit is within the noise" in text
    assert "the misfit is the linearisation" not in text
    assert "over the seeds" in text and "on every seed" not in text
    assert "falls to the reported 1.02 and keeps" in text
    assert "far from the 100-fold" in text


def test_the_verdicts_are_the_findings():
    full = summary(1.25, 0.99, 101.0, 0.21, 3)
    rows = {("cell", 1.0): full, ("cell", REDUCED): summary(1.04, 0.99, 17.0, 0.01, 0),
            ("weightless", 1.0): full, ("weightless", REDUCED): summary(0.995, 0.99, 1.3, 0.0, 0)}
    study = pd.DataFrame.from_dict({key: pd.concat([row, pd.Series({"noise_um": 8 * key[1]}, dtype=object)]) for key, row in rows.items()}, orient="index")
    study = study.astype(float)
    study.index.names = ["twin", "load_scale"]
    findings = linearisation_findings(study, pd.DataFrame({"sag_j2_mrad": [-0.58], "sag_j3_mrad": [0.33]}))
    assert findings.real and findings.noise_like and not findings.falls
    assert findings.against_reported == "lower" and findings.near_second_order
    assert findings.weightless_drop == pytest.approx(101.0 / 1.3)


def test_estimates_sit_beside_table_iv_with_the_truth():
    columns = ["unit", "identifiable", "mean", "half_width_3sd", "width_3sd_pct", "truth", "truth_inside",
               "published", "published_half_width_3sd", "published_width_pct"]
    nan = float("nan")
    estimates = pd.DataFrame(
        [["urad/(N m)", False, nan, nan, nan, 0.3, None, nan, nan, nan],
         ["urad/(N m)", True, 0.3026, 0.0048, 1.586, 0.302, True, 0.302, 0.0039, 1.3]],
        index=["k1", "k2"], columns=columns,
    )
    table = _estimates_table(estimates)
    assert list(table.loc["k1"]) == ["urad/(N m)", "not identifiable", "", "", 0.3, "", "–", "–", "–"]
    k2 = table.loc["k2"]
    assert k2["width"] == "1.6%" and k2["truth inside"] == "yes"
    assert k2["Table IV"] == 0.302 and k2["Table IV width"] == "1.3%"
    # the mean to the second digit of its ±3σ, as every table shows it (bayescal.numbers)
    assert (k2["mean"], k2["±3σ"]) == ("0.3026", "0.0048")
