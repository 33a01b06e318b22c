"""Shared fixtures of the third generator's tests: its arm, the Table III plan, and a bare cantilever built from its parts."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.twin.beams.campaign import read_plan
from bayescal.twin.beams.kr270 import kr270_class
from bayescal.twin.beams.robot import Compensator, Item, JointLaws, PointMass, Robot, Tool, beam_items


@pytest.fixture(scope="session")
def arm():
    return kr270_class()


@pytest.fixture(scope="session")
def table3(data_dir):
    """Table III's commanded joints (15, 6) rad and masses (15,) kg."""
    return read_plan(data_dir / "table3_plan.csv")


def cantilever(section, length: float, stations=(), masses=()) -> Robot:
    """A horizontal beam along the base x axis, clamped at the origin, as a generator robot.

    ``masses`` are ``(station index, kg)`` pairs: a weight on the node ending at ``stations[index]``;
    the hanging mass of :func:`~bayescal.twin.beams.statics.solve` acts on the tip.  No joints, no compensator.
    """
    items = (Item("fixed", "root", np.eye(4)), *beam_items("beam", length, list(stations), section))
    idle = Compensator(item0=0, p0=np.array([0.0, 1.0, 0.0]), item1=0, p1=np.zeros(3), K=0.0, s0=0.0, e_ref=1.0)
    return Robot(
        items=items,
        masses=tuple(PointMass(f"m{i}", 1 + i, np.zeros(3), kg) for i, kg in masses),
        compensator=idle,
        joints=JointLaws(k=np.zeros(6), rated=np.ones(6)),
        zero_offset=np.zeros(6),
        tool=Tool(item=len(items) - 1, load_point=np.zeros(3), markers={}),
        nominal=items,
    )
