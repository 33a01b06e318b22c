import dataclasses
from pathlib import Path

import numpy as np
import pytest

from bayescal.compensation.calibration import MAX_DRAWS, load_calibration, prior_draws
from bayescal.errors import InputError
from bayescal.units import URAD_PER_NM


def test_unidentified_k1_enters_with_its_prior_spread(cell, short_calibration):
    calibration = load_calibration(short_calibration["calibration"], cell)
    assert "k1" in calibration.unidentified
    k1 = calibration.own[:, 0]
    assert np.std(np.log(k1)) == pytest.approx(cell.compliance_log_sd, rel=0.02)
    # The median is the cell's value: the correction applies it, not the mean of the prior's draws
    # (exp(0.5²/2) = 1.13 times larger for the KR-270's log-sd 0.5).
    # (To 1e-6: with an even number of draws the median averages the two middle quantiles.)
    assert calibration.applied_own[0] == pytest.approx(cell.compliances[0], rel=1e-6)
    assert calibration.priors["k1"]["log_sd"] == cell.compliance_log_sd == 0.5
    # The identified ones are the posterior's: close to the config's values on a twin campaign of the config.
    assert np.mean(calibration.own[:, 3]) / URAD_PER_NM == pytest.approx(cell.compliances[3] / URAD_PER_NM, rel=0.1)
    assert calibration.n_draws <= MAX_DRAWS and calibration.spring.shape == (calibration.n_draws, 2)


def test_a_calibration_with_a_compensator_does_not_fit_a_cell_without_one(cell, short_calibration):
    bare = dataclasses.replace(cell, compensator=None)
    with pytest.raises(InputError, match="has none"):
        load_calibration(short_calibration["calibration"], bare)


def test_a_file_that_is_not_a_posterior_is_refused(cell, tmp_path):
    path = tmp_path / "x.nc"
    path.write_text("not netcdf")
    with pytest.raises(InputError, match="cannot read"):
        load_calibration(path, cell)


def test_a_calibration_of_another_robot_is_refused(cell, short_calibration, tmp_path):
    from bayescal.sampling.summary import load, save

    tree = load(short_calibration["calibration"])
    assert tree.attrs["robot"] == cell.robot.model.name
    tree.attrs["robot"] = "another_arm"
    save(tree, tmp_path / "other.nc")
    with pytest.raises(InputError, match="another_arm"):
        load_calibration(tmp_path / "other.nc", cell)


def test_the_prior_draws_are_its_quantiles_the_same_for_every_reader():
    draws = prior_draws(0.3, 0.5, 2000, 0)
    assert np.median(draws) == pytest.approx(0.3, rel=1e-6)
    assert np.array_equal(draws, prior_draws(0.3, 0.5, 2000, 0))
    # Another joint gets the same values in another order, so that two unidentified joints are not paired draw by draw.
    other = prior_draws(0.3, 0.5, 2000, 1)
    assert np.array_equal(np.sort(draws), np.sort(other)) and not np.array_equal(draws, other)
    assert np.std(np.log(draws)) == pytest.approx(0.5, rel=0.01)


def test_a_cell_states_its_prior_of_what_campaigns_cannot_identify(cell, tmp_path):
    from bayescal.cell.config import load_cell

    text = Path(cell.source).read_text().replace("k_log_sd = 0.5", "k_log_sd = 0.8").replace('urdf = "', f'urdf = "{Path(cell.source).parent}/')
    (tmp_path / "cell.toml").write_text(text)
    wider = load_cell(tmp_path / "cell.toml")
    assert wider.compliance_log_sd == 0.8 and wider.compliance_log_sd_source.endswith("[joints] k_log_sd")
    (tmp_path / "pct.toml").write_text(text.replace("k_log_sd = 0.8", "k_log_sd = 50"))
    with pytest.raises(InputError, match="k_log_sd"):
        load_cell(tmp_path / "pct.toml")
