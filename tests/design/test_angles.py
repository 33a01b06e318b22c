"""Tests of bayescal.design.angles: what each extra q2 angle buys, and what K_c and s0 would cost."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from bayescal.errors import InputError
from bayescal.cell.config import load_cell
from bayescal.design.angles import identification_cost, q2_angle_study, width_targets


def test_study_table_and_noise_scaling(cell):
    with ThreadPoolExecutor(2) as executor:
        table = q2_angle_study(cell, angles=[3, 4], per_angle=[1], candidates_per_angle=2, seed=3, executor=executor)
    assert list(table[["angles", "per_angle", "noise_fraction"]].itertuples(index=False, name=None)) == [
        (3, 1, 1.0), (3, 1, 0.1), (4, 1, 1.0), (4, 1, 0.1)
    ]
    full, tenth = table[table.noise_fraction == 1.0], table[table.noise_fraction == 0.1]
    np.testing.assert_allclose(tenth["K_c_width_3sd_pct"].to_numpy(), full["K_c_width_3sd_pct"].to_numpy() / 10)
    assert table["k1_width_3sd_pct"].isna().all()  # hanging loads never turn A1
    assert (full["K_c_width_3sd_pct"] > 0).all() and (full["test_pose_rms_mm"] > 0).all()


def test_two_angles_are_refused(cell):
    with pytest.raises(InputError, match="at least 3"):
        q2_angle_study(cell, angles=[2, 3], per_angle=[1])


def test_identification_cost_reads_the_table():
    table = pd.DataFrame(
        {
            "angles": [3, 5, 3, 5],
            "per_angle": [1, 3, 1, 3],
            "noise_fraction": [1.0, 1.0, 0.1, 0.1],
            "K_c_width_3sd_pct": [400.0, 200.0, 40.0, 20.0],
            "s0_width_3sd_pct": [100.0, 59.0, 10.0, 5.9],
        }
    )
    cost = identification_cost(table, repeats=3, targets={"Table IV": {"K_c": 21.5, "s0": 5.9}}).set_index("noise_fraction")
    # at the full noise the best plan falls short by 10x on s0: 100x the repeats, or a tenth of the noise
    assert not cost.loc[1.0, "reached"] and cost.loc[1.0, "angles"] == 5
    assert cost.loc[1.0, "repeats_needed"] == 300 and cost.loc[1.0, "noise_fraction_needed"] == pytest.approx(0.1)
    assert cost.loc[0.1, "reached"] and cost.loc[0.1, "angles"] == 5 and cost.loc[0.1, "repeats_needed"] == 3


def test_width_targets_read_the_published_widths(cell, data_dir):
    targets = width_targets(cell)
    # Table IV: K_c = 144 ± 31 N/mm, s0 = 458 ± 27 mm (±3σ)
    assert targets["Table IV"] == pytest.approx({"K_c": 100 * 31 / 144, "s0": 100 * 27 / 458})
    assert targets["5 %"] == {"K_c": 5.0, "s0": 5.0}
    # a robot that publishes no results is asked the fixed width alone
    assert list(width_targets(load_cell(data_dir / "robots" / "arm6_j3.toml"))) == ["5 %"]
