import tempfile
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from bayescal.cell.campaign import read_campaign
from bayescal.cell.config import load_cell
from bayescal.critique.covariates import campaign_rows
from bayescal_studies.studies.critique_rates import GENERATORS
from bayescal_studies.studies.detection_ceiling import ceiling_rates, detection_ceiling, planted_share


def _rows(data_dir, generator, effect, seed):
    """The rows of a twin campaign with ``effect`` planted at its default and of the one with nothing, same seed."""
    cell = load_cell(data_dir / "kr270.toml")
    rows = []
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        for which, multiple in ((effect, 1.0), ("none", 0.0)):
            (Path(folder) / which).mkdir()
            path = GENERATORS[generator].write(which, multiple, seed, False, Path(folder) / which, cell, data_dir / "table3_plan.csv")[0]
            rows.append(campaign_rows(cell, read_campaign(path, cell=cell)))
    return rows


def _by_state(rows, share):
    """(configurations × markers, repeats, 3) the share of each marker of each configuration in its repeats."""
    order = np.lexsort((rows.repeat, rows.marker, rows.config))
    return share[order].reshape(-1, len(np.unique(rows.repeat)), 3)


@pytest.mark.parametrize("generator", ["twin", "beams"])
def test_a_static_effect_leaves_the_same_share_in_every_repeat(data_dir, generator):
    # the tool's mount softened: the same deflection every time the same load hangs in the same configuration, so a
    # share that differs between repeats would carry the tracker's noise (the two campaigns not sharing its draws)
    planted, none = _rows(data_dir, generator, "tool_compliance", seed=4)
    share = _by_state(planted, planted_share(planted, none))
    assert np.sqrt(np.mean(share**2)) > 10e-6
    assert np.abs(share - share.mean(axis=1, keepdims=True)).max() < 1e-3 * np.abs(share).max()


def test_the_share_of_an_effect_that_moves_the_poses_leaves_the_classical_models_part_out(data_dir):
    # 30 times the spring's stiffness turns joint 2 by about 3 degrees unloaded: the campaigns' raw difference is then
    # mostly the pose's change, which the classical model at the planted campaign's poses fits (its amplitude ~0 on top
    # of that model); the share has the planted effect's own amplitude, 1
    planted, none = _rows(data_dir, "twin", "compensator", seed=0)
    assert np.abs(planted.q - none.q).max() > np.radians(1)
    design = planted.design.reshape(3 * len(planted), -1)

    def amplitude(column):
        fitted = np.linalg.lstsq(np.column_stack([design, column.reshape(-1)]), planted.y.reshape(-1), rcond=None)[0]
        return fitted[-1]

    assert abs(amplitude(planted.y - none.y)) < 0.1
    assert amplitude(planted_share(planted, none)) == pytest.approx(1.0, abs=0.1)


def test_the_oracle_is_named_far_above_the_noise_and_not_far_below_it(data_dir):
    with ThreadPoolExecutor(1) as executor:
        strong = detection_ceiling(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "twin", ["compensator"],
                                   seeds=range(4), executor=executor)
        weak = detection_ceiling(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "twin", ["tool_compliance"],
                                 multiples=[0.2], seeds=range(4), executor=executor)
    assert strong["named"].all() and (strong["noncentrality"] > 30).all()
    # the family's form is the planted spring's law, linearised: it takes up nearly all of the share
    assert (strong["captured"] > 0.9).all()
    assert not weak["named"].any() and (weak["noncentrality"] < 1).all()
    # a static effect's share is the same in every seed on one plan: its noncentrality moves only with the tracker's
    # noise model, evaluated at the readings
    assert weak["noncentrality"].std() < 1e-2 * weak["noncentrality"].mean()


def test_the_ceiling_refuses_what_has_no_planted_share(data_dir):
    with pytest.raises(ValueError, match="unknown generator"):
        detection_ceiling(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "nowhere", ["drift"])
    with pytest.raises(ValueError, match="none"):
        detection_ceiling(data_dir / "kr270.toml", data_dir / "table3_plan.csv", "twin", ["none"])


def test_the_rates_count_the_campaigns_named_and_above_the_separation_bound():
    table = pd.DataFrame({"generator": "twin", "effect": "backlash", "multiple": 1.0, "seed": range(4),
                          "share_rms_um": [10.0, 20.0, 30.0, 40.0], "noncentrality": [4.0, 12.0, 20.0, 90.0], "captured": [0.1, 0.2, 0.4, 0.6],
                          "delta_elpd": [0.5, 3.0, 9.0, 40.0], "se": [1.0, 2.0, 3.0, 8.0], "named": [False, False, True, True]})
    row = ceiling_rates(table).iloc[0]
    assert (row["n"], row["named"], row["separable"]) == (4, 0.5, 0.5)
    assert row["named_se"] == pytest.approx(0.25)
    assert (row["share_rms_um"], row["noncentrality"], row["captured"]) == (25.0, 16.0, pytest.approx(0.3))


@pytest.mark.parametrize("generator, effect, multiple, below", [
    ("twin", "tool_compliance", 1.0, True),  # docs/critique.md: no candidate reaches 80 % first at the twin's default
    ("twin", "tool_compliance", 2.0, False),
    ("beams", "compensator", 2.0, True),  # the third generator's gas spring: 3 μm rms of the deflections at twice its default
    ("beams", "lost_motion", 1.0, False),
])
def test_the_documented_ceilings_fall_on_their_side_of_the_separation_bound(data_dir, generator, effect, multiple, below):
    from bayescal.critique.rule import SEPARABLE_CHI2

    with ThreadPoolExecutor(1) as executor:
        table = detection_ceiling(data_dir / "kr270.toml", data_dir / "table3_plan.csv", generator, [effect],
                                  multiples=[multiple], seeds=[0], executor=executor)
    assert (table["noncentrality"].iloc[0] < SEPARABLE_CHI2) == below
