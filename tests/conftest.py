"""Fixtures shared by the tests: the repository's data files and the KR-270 cell built from them.

Paths are resolved from this file, so the tests pass from any working directory.
"""

import ast
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from bayescal.cell.campaign import write_campaign
from bayescal.cell.config import load_cell
from bayescal.cell.plan import read_plan

DATA = Path(__file__).resolve().parents[1] / "data"

# One BLAS thread, as `bayescal` itself sets before NumPy loads (pytest loads NumPy first, for the
# warning filter of pyproject.toml): the samplers' matrices are a few columns wide, and on a busy
# machine BLAS threads spin.  Measured: a test robot's calibration took 3.4 s of CPU with two BLAS
# threads on the shared 2-core machine, 0.44 s with one.
threadpool_limits(1, user_api="blas")


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's ``data/`` folder."""
    return DATA


@pytest.fixture(scope="session")
def cell():
    """The KR-270 calibration cell of ``data/kr270.toml``."""
    return load_cell(DATA / "kr270.toml")


PLANAR_LINKS = (1.0, 0.5)
"""Link lengths (m) of :func:`planar_arm`."""


@pytest.fixture(scope="session")
def planar_arm(tmp_path_factory):
    """Two revolute joints about the base z axis, links :data:`PLANAR_LINKS` along x, the flange at the tip:
    small enough to work eq 31 by hand, and weightless about its axes (gravity along -z exerts no torque)."""
    from bayescal.robot.kinematics import Robot

    l1, l2 = PLANAR_LINKS
    urdf = tmp_path_factory.mktemp("planar") / "planar.urdf"
    inertia = '<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'
    urdf.write_text(
        f"""<robot name="planar">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><origin xyz="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="l1">{inertia}</link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="{l1} 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="l2">{inertia}</link>
  <joint name="tip" type="fixed"><parent link="l2"/><child link="flange"/><origin xyz="{l2} 0 0"/></joint>
  <link name="flange"/>
</robot>"""
    )
    return Robot.from_urdf(urdf)


@pytest.fixture(scope="session")
def robot(cell):
    """The KR-270 robot of the cell's URDF."""
    return cell.robot


@pytest.fixture(scope="session")
def plan(cell):
    """The paper's Table III plan."""
    return read_plan(DATA / "table3_plan.csv", cell.robot)


@pytest.fixture(scope="session")
def compensator_plan(cell):
    """``data/compensator_plan.csv``: 10 q2 angles x 3 configurations at 280 kg, designed to identify the compensator."""
    return read_plan(DATA / "compensator_plan.csv", cell.robot)


@pytest.fixture(scope="session")
def campaign_csv(cell, plan, tmp_path_factory) -> Path:
    """A campaign CSV of the Table III plan measured once on the twin (seed 1): 45 rows, read-only for tests."""
    from bayescal.twin.simulator import DigitalTwin

    campaign = DigitalTwin(cell).simulate(plan, 1, np.random.default_rng(1))
    path = tmp_path_factory.mktemp("campaign") / "campaign.csv"
    write_campaign(campaign, path, comments=["twin, Table III, 1 repeat, seed 1"])
    return path


@pytest.fixture(scope="session")
def short_calibration(cell, campaign_csv, tmp_path_factory) -> dict[str, Path]:
    """Posterior files of a short run of the whole job: the Table I geometry, then the ``campaign_csv`` calibration.

    Small sampler sizes (2 chains of 100-150 draws) keep it to a few seconds; the
    posteriors are too short to have converged, which the files' readers must show,
    not hide.  Returns the paths ``geometry``, ``calibration``, ``campaign`` and ``config``.
    """
    import warnings

    from bayescal.geometry.arcs import read_arc_points
    from bayescal.geometry.posterior import GeometryPosteriorModel, geometry_sampler
    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.inference.priors import posterior_geometry
    from bayescal.cell.campaign import read_campaign
    from bayescal.sampling.gibbs import GibbsSampler

    folder = tmp_path_factory.mktemp("short_calibration")
    paths = {"geometry": folder / "geometry.nc", "calibration": folder / "calibration.nc", "campaign": campaign_csv, "config": DATA / "kr270.toml"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        points = read_arc_points(DATA / "table1_geometry.csv")
        GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=150, n_draws=100)).fit(points, 0).save(paths["geometry"])
        model = ElastostaticModel.from_cell(
            cell, posterior_geometry(paths["geometry"]), sampler=GibbsSampler(n_chains=2, n_tune=100, n_draws=150)
        )
        model.fit(read_campaign(campaign_csv, cell=cell), 0).save(paths["calibration"])
    return paths


def random_plan(cell, n: int, rng):
    """A plan of ``n`` random configurations inside the KR-270's working range, loads of 200-300 kg.

    The ranges keep the arm in front of the robot with the wrist away from its
    singularity (|q5| > 20 deg), as a user's own plan would; they are not Table III's.
    """
    from bayescal.cell.plan import Plan
    from bayescal.units import DEG

    low = np.array([-90.0, -140.0, -20.0, -170.0, 20.0, -170.0]) * DEG
    high = np.array([90.0, -10.0, 110.0, 170.0, 110.0, 170.0]) * DEG
    q = rng.uniform(low, high, size=(n, 6))
    q[:, 4] *= rng.choice([-1.0, 1.0], size=n)
    return Plan(q=q, load_kg=rng.uniform(200.0, 300.0, size=n), lines=np.zeros(n, dtype=int), source="random plan")


@pytest.fixture(scope="session")
def make_random_plan():
    """``make_random_plan(cell, n, rng)``: random feasible configurations (see :func:`random_plan`)."""
    return random_plan


@pytest.fixture(scope="session")
def twin_campaign(cell, plan):
    """``twin_campaign(effects, seed, plan=None, cell=None, repeats=3)``: a campaign of the twin with effects planted."""
    from bayescal.twin.effects import parse_effect
    from bayescal.twin.simulator import DigitalTwin

    def make(effects=(), seed=0, plan_=None, cell_=None, repeats=3):
        rng = np.random.default_rng(seed)
        twin = DigitalTwin(cell_ or cell, [parse_effect(e) for e in effects])
        return twin.simulate(plan_ or plan, repeats, rng)

    return make


@pytest.fixture(scope="session")
def short_exact_fit(cell, plan):
    """A short exact-model fit (Gibbs, 2 chains of 100 draws) of a Table III campaign on the twin, seed 1."""
    import warnings

    from bayescal.inference.elastostatic import ElastostaticModel
    from bayescal.sampling.gibbs import GibbsSampler
    from bayescal.twin.simulator import DigitalTwin

    campaign = DigitalTwin(cell).simulate(plan, 3, np.random.default_rng(1))
    with warnings.catch_warnings():
        # short chains on a campaign that cannot identify k1 and the spring
        warnings.simplefilter("ignore")
        return ElastostaticModel.from_cell(cell, sampler=GibbsSampler(n_chains=2, n_tune=50, n_draws=100)).fit(campaign, 1)


@pytest.fixture(scope="session")
def modules_loaded_by():
    """``loaded(arguments, modules)``: which of ``modules`` a fresh interpreter has imported once ``bayescal arguments``
    has run in it (a sorted list), to hold a command's start-up to the libraries it uses."""

    def loaded(arguments, modules):
        script = ("import sys\nfrom bayescal.cli import main\n"
                  f"main({[str(a) for a in arguments]!r})\n"
                  f"print(sorted(m for m in {tuple(modules)!r} if m in sys.modules))\n")
        root = str(Path(__file__).resolve().parents[1])
        environment = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, env=environment)
        return ast.literal_eval(done.stdout.strip().splitlines()[-1])

    return loaded
