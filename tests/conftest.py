"""Fixtures shared by the tests: the repository's data files and the KR-270 cell built from them.

Paths are resolved from this file, so the tests pass from any working directory.
"""

from pathlib import Path

import numpy as np
import pytest

from bayescal.cell.campaign import write_campaign
from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan

DATA = Path(__file__).resolve().parents[1] / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's ``data/`` folder."""
    return DATA


@pytest.fixture(scope="session")
def cell():
    """The KR-270 calibration cell of ``data/kr270.toml``."""
    return load_cell(DATA / "kr270.toml")


@pytest.fixture(scope="session")
def robot(cell):
    """The KR-270 robot of the cell's URDF."""
    return cell.robot


@pytest.fixture(scope="session")
def plan(cell):
    """The paper's Table III plan."""
    return read_plan(DATA / "table3_plan.csv", cell.robot)


@pytest.fixture(scope="session")
def campaign_csv(cell, plan, tmp_path_factory) -> Path:
    """A campaign CSV of the Table III plan measured once on the twin (seed 1): 45 rows, read-only for tests."""
    from bayescal.twin.simulator import DigitalTwin

    campaign = DigitalTwin(cell).simulate(plan, 1, np.random.default_rng(1))
    path = tmp_path_factory.mktemp("campaign") / "campaign.csv"
    write_campaign(campaign, path, comments=["twin, Table III, 1 repeat, seed 1"])
    return path
