"""The exact model's deflections of a whole campaign, solved together, against one configuration at a time."""

import numpy as np
import pytest

from bayescal.cell.config import load_cell
from bayescal.inference.equations import deflection_equations
from bayescal.inference.exact import campaign_deflections, exact_deflections, linearisation_offset
from bayescal.studies.elastostatic_coverage import random_plan
from bayescal.twin.simulator import DigitalTwin


def _one_at_a_time(cell, campaign, equations, compliances, k2):
    expected = np.empty((len(campaign), 3))
    for config in np.unique(campaign.config):
        rows = np.flatnonzero(campaign.config == config)
        q = campaign.q[rows[0]]
        k = np.array(compliances)
        if equations.joint is not None:
            k[equations.joint] = cell.compensator.own_compliance(q[equations.joint], k2[equations.angle[3 * rows[0]]])
        expected[rows] = exact_deflections(
            cell.robot, q, campaign.wrench[rows[0]], k, cell.compensator,
            unloaded_positions=campaign.p0[rows], load_point=cell.load_point, compensated_joint=equations.joint,
        )
    return expected


@pytest.mark.parametrize("name", ["kr270.toml", "robots/arm7.toml", "robots/arm6.toml", "robots/track_arm6.toml"])
def test_campaign_deflections_equal_the_loop_over_configurations(data_dir, name):
    cell = load_cell(data_dir / name)
    rng = np.random.default_rng(11)
    campaign = DigitalTwin(cell).simulate(random_plan(cell, 4, 2, rng), 2, rng)
    joint = cell.compensated_joint if cell.compensator else None
    equations, _, _ = deflection_equations(cell.robot, campaign, joint=joint)
    compliances = np.asarray(cell.compliances) * rng.uniform(0.8, 1.25, cell.robot.nq)
    k2 = np.empty(0)
    if joint is not None:
        k2 = cell.compensator.equivalent_compliance(equations.compensated_angles, compliances[joint]) * rng.uniform(0.9, 1.1, equations.compensated_angles.size)
    expected = _one_at_a_time(cell, campaign, equations, compliances, k2)
    batched = campaign_deflections(cell.robot, campaign, equations, compliances, k2, cell.compensator, cell.load_point)
    # Deflections of millimetres, the difference of positions of metres: equal to a picometre, the positions' rounding.
    assert np.abs(expected).max() > 1e-4
    np.testing.assert_allclose(batched, expected, rtol=0, atol=1e-12)
    offset = linearisation_offset(cell.robot, campaign, equations, compliances, k2, cell.compensator, cell.load_point)
    assert offset.shape == (equations.n,) and np.all(np.isfinite(offset))
