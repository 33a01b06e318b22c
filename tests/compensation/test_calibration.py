import dataclasses

import numpy as np
import pytest

from bayescal.compensation.calibration import MAX_DRAWS, UNIDENTIFIED_LOG_SD, load_calibration
from bayescal.errors import InputError
from bayescal.units import URAD_PER_NM


def test_unidentified_k1_enters_with_its_prior_spread(cell, short_calibration):
    calibration = load_calibration(short_calibration["calibration"], cell, np.random.default_rng(0))
    assert "k1" in calibration.unidentified
    k1 = calibration.own[:, 0]
    assert np.std(np.log(k1)) == pytest.approx(UNIDENTIFIED_LOG_SD, rel=0.15)
    assert np.exp(np.mean(np.log(k1))) == pytest.approx(cell.compliances[0], rel=0.1)
    # The identified ones are the posterior's: close to the config's values on a twin campaign of the config.
    assert np.mean(calibration.own[:, 3]) / URAD_PER_NM == pytest.approx(cell.compliances[3] / URAD_PER_NM, rel=0.1)
    assert calibration.n_draws <= MAX_DRAWS and calibration.spring.shape == (calibration.n_draws, 2)


def test_a_calibration_with_a_compensator_does_not_fit_a_cell_without_one(cell, short_calibration):
    bare = dataclasses.replace(cell, compensator=None)
    with pytest.raises(InputError, match="has none"):
        load_calibration(short_calibration["calibration"], bare, np.random.default_rng(0))


def test_a_file_that_is_not_a_posterior_is_refused(cell, tmp_path):
    path = tmp_path / "x.nc"
    path.write_text("not netcdf")
    with pytest.raises(InputError, match="cannot read"):
        load_calibration(path, cell, np.random.default_rng(0))


def test_a_calibration_of_another_robot_is_refused(cell, short_calibration, tmp_path):
    from bayescal.sampling.summary import load, save

    tree = load(short_calibration["calibration"])
    assert tree.attrs["robot"] == cell.robot.model.name
    tree.attrs["robot"] = "another_arm"
    save(tree, tmp_path / "other.nc")
    with pytest.raises(InputError, match="another_arm"):
        load_calibration(tmp_path / "other.nc", cell, np.random.default_rng(0))
