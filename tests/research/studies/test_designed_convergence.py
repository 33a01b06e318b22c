"""The workflow agrees with itself: plans `bayescal plan` designs, measured and calibrated with the defaults, converge."""

import pytest

from bayescal.sampling.summary import ESS_LIMIT, R_HAT_LIMIT
from bayescal_studies.studies.designed_convergence import Design, default_designs, designed_plan_convergence


def test_the_designs_cycle_through_criteria_and_sizes_with_seeds_of_their_own():
    designs = default_designs(9, first_seed=100)
    assert {d.criterion for d in designs} == {"test-pose", "compensator", "d-optimal"}
    assert {(d.angles, d.per_angle) for d in designs} == {(5, 3), (4, 3), (6, 2)}
    assert [d.seed for d in designs] == list(range(100, 109))
    assert designs[0] == Design("test-pose", 5, 3, "linear", 100)


@pytest.mark.slow
def test_the_default_calibration_converges_on_every_designed_plan(cell):
    # 20 designs searched with the linear model (as `make demo` does) and 4 with the exact one (plan's default),
    # each measured by the twin and by the independent generator: 48 campaigns.
    designs = default_designs(20, "linear") + default_designs(4, "exact", first_seed=100)
    table = designed_plan_convergence(cell, designs, seed=26)
    assert len(table) == 48
    assert (table["r_hat_max"] <= R_HAT_LIMIT).all(), table.loc[table["r_hat_max"] > R_HAT_LIMIT].to_string()
    assert (table["ess_bulk_min"] >= ESS_LIMIT).all() and (table["ess_tail_min"] >= ESS_LIMIT).all()
    assert table["converged"].all()
