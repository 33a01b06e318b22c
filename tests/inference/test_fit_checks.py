"""Tests of bayescal.inference.fit_checks: what a campaign and its fit say about themselves."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.errors import InputError
from bayescal.inference.closedform import ClosedForm
from bayescal.inference.equations import deflection_equations, deflection_noise
from bayescal.inference.fit_checks import IMPLAUSIBLE_RATIO, check_scale, calibration_lack_of_fit, residual_chi2
from bayescal.twin.simulator import DigitalTwin


def _closed_form(values: np.ndarray, relative_sd: float = 0.01) -> ClosedForm:
    """Per-angle estimates of joints 1 and 3 (``values``, rad/(N·m)) with a relative sd."""
    n = values.size
    return ClosedForm(
        per_angle=values, columns=[(0, None), (2, None)][:n], cov=np.diag((relative_sd * values) ** 2), sigma=np.ones(3),
        compliances=np.full(6, np.nan), spring=None, k2=np.zeros(0), k2_sd=np.zeros(0),
    )


@pytest.mark.parametrize(("factor", "message"), [(1000.0, "1e\\+03 times the config's: are the positions in another unit"),
                                                 (-1.0, "negative joint compliances: is the wrench's sign flipped")])
def test_compliances_a_unit_slip_or_a_sign_away_from_the_configs_are_refused(cell, campaign_csv, factor, message):
    campaign = read_campaign(campaign_csv, cell=cell)
    nominal = cell.compliances
    check_scale(campaign, _closed_form(nominal[[0, 2]] * 1.3), nominal)
    with pytest.raises(InputError, match=message):
        check_scale(campaign, _closed_form(nominal[[0, 2]] * factor), nominal)
    # Only determined compliances count: an estimate as uncertain as itself says nothing of the unit.
    check_scale(campaign, _closed_form(nominal[[0, 2]] * factor, relative_sd=1.0), nominal)
    assert IMPLAUSIBLE_RATIO < 1000


def test_chi2_per_dof_measures_the_residuals_against_the_trackers_noise(cell, campaign_csv):
    campaign = read_campaign(campaign_csv, cell=cell)
    sd = np.repeat(deflection_noise(cell.tracker, campaign), 3)
    residual = sd * np.random.default_rng(0).standard_normal(sd.size)
    chi2 = residual_chi2(cell.tracker, campaign, residual, n_free=10)
    assert abs(chi2 - 1.0) < 4 * np.sqrt(2.0 / (sd.size - 10))
    assert residual_chi2(cell.tracker, campaign, 2 * residual, n_free=10) == pytest.approx(4 * chi2)
    assert residual_chi2(None, campaign, residual, n_free=10) is None


def test_the_lack_of_fit_test_needs_repeats_and_finds_a_misfit_of_the_configuration_means(cell, plan):
    def equations_of(campaign, rng):
        """The campaign's equations with observations the linear model makes exactly, plus the tracker's noise."""
        equations = deflection_equations(cell.robot, campaign, tracker=cell.tracker, joint=cell.compensated_joint)[0]
        sd = np.repeat(deflection_noise(cell.tracker, campaign), 3)
        return replace(equations, y=equations.design @ cell.compliances + sd * rng.standard_normal(sd.size)), sd

    rng = np.random.default_rng(3)
    single = DigitalTwin(cell).simulate(plan, 1, np.random.default_rng(1))
    assert calibration_lack_of_fit(cell.tracker, single, equations_of(single, rng)[0]) is None
    repeated = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(2))
    equations, sd = equations_of(repeated, rng)
    fitted = calibration_lack_of_fit(cell.tracker, repeated, equations)
    assert not fitted.significant()
    # The calibration model is fitted, not taken at the config's compliances: scaled, they fit as well.
    scaled = calibration_lack_of_fit(cell.tracker, repeated, replace(equations, y=equations.y + 0.3 * equations.design @ cell.compliances))
    assert scaled.statistic == pytest.approx(fitted.statistic, rel=1e-4)
    # The same offset in every repeat of a configuration and marker: the repeats agree, the model does not.
    cells = np.unique(np.column_stack([repeated.config, repeated.marker]).astype(str), axis=0, return_inverse=True)[1].reshape(-1)
    offset = rng.standard_normal((cells.max() + 1, 3))[cells].reshape(-1) * 3 * sd
    assert calibration_lack_of_fit(cell.tracker, repeated, equations, -offset).significant()


class _Fit:
    """A calibration's diagnostics at a given χ²/dof: what check_fits_campaign reads of it."""

    def __init__(self, chi2):
        self.chi2 = chi2

    def diagnostics(self):
        return {"chi2_per_dof": self.chi2}


def test_a_calibration_far_off_its_campaign_is_refused_naming_the_files():
    from bayescal.inference.fit_checks import MAX_CHI2_PER_DOF, check_fits_campaign

    for chi2 in (None, 0.87, MAX_CHI2_PER_DOF):
        check_fits_campaign(_Fit(chi2), "campaign.csv", "cell.toml", "calibration.nc")
    with pytest.raises(InputError, match=r"fits the campaign campaign.csv with χ²/dof = 3588.00, above 100 \(residuals 60 times the "
                                         r"tracker noise of cell.toml\)") as error:
        check_fits_campaign(_Fit(3588.0), "campaign.csv", "cell.toml", "calibration.nc")
    assert error.value.source == "calibration.nc"
