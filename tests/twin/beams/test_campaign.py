"""Generated campaigns: deterministic, effects of magnitude 0 equal to none, nests fixed in the world up to noise
and drift, a realistic clock, and files that bayescal's readers and `bayescal calibrate` take."""

import json

import numpy as np
import pandas as pd
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.cli import main
from bayescal.errors import InputError
from bayescal.twin.beams import EFFECTS, generate_campaign
from bayescal.twin.beams.effects import OUTLIER_COUNT
from bayescal.twin.beams.tracker import POSITION_MM, TrackerLaw
from bayescal.units import MM

POSITIONS = ["x0_mm", "y0_mm", "z0_mm", "x1_mm", "y1_mm", "z1_mm"]


@pytest.fixture(scope="module")
def plan(data_dir):
    return data_dir / "table3_plan.csv"


@pytest.fixture(scope="module")
def none(plan):
    return generate_campaign(plan, seed=5, nests=True)


@pytest.mark.parametrize("effect", EFFECTS[1:])
def test_zero_magnitude_is_none(plan, none, effect):
    zero = generate_campaign(plan, effect=effect, magnitude=0.0, seed=5, nests=True)
    pd.testing.assert_frame_equal(zero.rows, none.rows, check_exact=True)
    pd.testing.assert_frame_equal(zero.nests, none.nests, check_exact=True)


@pytest.mark.parametrize("effect", EFFECTS[1:])
def test_each_effect_moves_the_readings(plan, none, effect):
    planted = generate_campaign(plan, effect=effect, seed=5, nests=True)
    moved = np.abs(planted.rows[POSITIONS].to_numpy() - none.rows[POSITIONS].to_numpy()).max()
    # The weakest, the compensator's law, still moves the unloaded poses by tenths of a mm.
    assert moved > 0.01


@pytest.mark.parametrize("effect", EFFECTS)
def test_the_truth_is_plain_data(plan, effect):
    truth = json.loads(json.dumps(generate_campaign(plan, effect=effect, seed=1).truth))
    assert truth["effect"] == effect and truth["tracker_position_mm"] == list(POSITION_MM)
    assert (truth["drift"] is not None) == (effect == "drift") and bool(truth["outliers"]) == (effect == "outliers")
    assert bool(truth["planted"]) == (effect not in ("none", "outliers", "drift"))


def test_same_seed_same_files_other_seed_other_readings(plan, none, tmp_path):
    again = generate_campaign(plan, seed=5, nests=True)
    first, second = none.write(tmp_path / "a.csv"), again.write(tmp_path / "b.csv")
    for one, two in zip(first, second):
        assert one.read_text().splitlines()[1:] == two.read_text().splitlines()[1:]
    other = generate_campaign(plan, seed=6, nests=True)
    assert not np.allclose(other.rows[POSITIONS], none.rows[POSITIONS], atol=1e-3)


def test_outliers_are_where_the_truth_says(plan, none):
    planted = generate_campaign(plan, effect="outliers", seed=5, nests=True)
    difference = (planted.rows[POSITIONS] - none.rows[POSITIONS]).to_numpy()
    assert np.count_nonzero(np.abs(difference).max(axis=1) > 1e-4) <= OUTLIER_COUNT
    for gross in planted.truth["outliers"]:
        row = np.flatnonzero((planted.rows["config"] == gross["config"]) & (planted.rows["repeat"] == gross["repeat"]) & (planted.rows["marker"] == gross["marker"]))[0]
        columns = slice(0, 3) if gross["reading"] == "unloaded" else slice(3, 6)
        np.testing.assert_allclose(difference[row, columns], gross["error_mm"], atol=2e-5)
        assert 0.3 <= np.linalg.norm(gross["error_mm"]) <= 1.0


def nest_errors(campaign, drift=True):
    """Each nest reading minus its true place (and the planted drift at its time), in sds of the tracker across its line of sight."""
    nests = campaign.nests
    true = np.array([campaign.truth["nests_mm"][name] for name in nests["nest"]])
    expected = true + (campaign.drift_mm(true, nests["t_s"].to_numpy()) if drift else 0.0)
    _, across = TrackerLaw(np.asarray(POSITION_MM) * MM).sigmas(true * MM)
    return (nests[["x_mm", "y_mm", "z_mm"]].to_numpy() - expected) / (across[:, None] / MM)


@pytest.mark.parametrize("effect", ["none", "drift"])
def test_nests_stay_in_place_up_to_noise_and_drift(plan, effect):
    campaign = generate_campaign(plan, effect=effect, seed=8, nests=4)
    errors = nest_errors(campaign)
    assert np.abs(errors).max() < 5.0
    # Across the beam one sd, along it a third to a half of that: the mean square per coordinate is 0.6-0.8.
    assert 0.5 < np.mean(errors**2) < 1.0


@pytest.mark.parametrize("seed", [0, 8])
def test_the_planted_drift_is_in_the_nest_readings(plan, seed):
    campaign = generate_campaign(plan, effect="drift", seed=seed, nests=3)
    with_drift, without = np.mean(nest_errors(campaign) ** 2), np.mean(nest_errors(campaign, drift=False) ** 2)
    # Measured over seeds 0-4: removing the planted drift lowers the mean square by 31-50 %.
    assert with_drift < 0.8 * without


@pytest.mark.parametrize("order", ["together", "passes"])
def test_the_clock(plan, order):
    campaign = generate_campaign(plan, seed=2, nests=True, order=order)
    rows, nests = campaign.rows, campaign.nests
    assert (rows["t1_s"] - rows["t0_s"]).min() > 180.0
    assert np.all(np.diff(rows["t0_s"]) > 0)
    rounds = np.sort(nests["t_s"].to_numpy())[:: 3]
    assert np.diff(rounds).max() < 15 * 60
    assert 3 * 3600 < campaign.truth["duration_s"] < 9 * 3600
    if order == "passes":
        config1 = rows[rows["config"] == 1].groupby("repeat")["t0_s"].min().to_numpy()
        assert np.diff(config1).min() > 3600.0


def test_files_are_read_by_the_cell_and_calibrate(plan, none, tmp_path, cell, data_dir, capsys):
    from bayescal.cell.nests import read_nests

    path, nests_path = none.write(tmp_path / "campaign.csv")
    campaign = read_campaign(path, cell=cell, markers=("M1", "M2", "M3"))
    assert len(campaign) == 15 * 3 * 3 and campaign.times is not None
    assert len(read_nests(nests_path)) == len(none.nests)
    status = main(["calibrate", str(path), "--config", str(data_dir / "kr270.toml"), "--draws", "100"])
    assert status == 0, capsys.readouterr().err


def test_bad_arguments_are_named(plan, tmp_path):
    with pytest.raises(InputError, match="unknown effect 'backlash'"):
        generate_campaign(plan, effect="backlash")
    with pytest.raises(InputError, match="magnitude"):
        generate_campaign(plan, effect="drift", magnitude=-1.0)
    with pytest.raises(InputError, match="reference nests"):
        generate_campaign(plan, nests=7)
    bad = tmp_path / "plan.csv"
    bad.write_text("q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n0,0,0,0,0,0\n")
    with pytest.raises(InputError, match="load_kg"):
        generate_campaign(bad)
