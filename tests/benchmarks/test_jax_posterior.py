"""The JAX posterior that ``benchmarks/bench_nuts.py`` samples with NUTS is the package's posterior."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

jax = pytest.importorskip("jax")
pytest.importorskip("numpyro")

from bayescal.inference.elastostatic import ElastostaticModel  # noqa: E402
from bayescal.inference.priors import GeometryPrior  # noqa: E402
from bayescal.sampling.collapsed import CollapsedSampler  # noqa: E402
from bayescal.sampling.gibbs import GibbsSampler  # noqa: E402
from bayescal.twin.simulator import DigitalTwin  # noqa: E402

SOURCE = Path(__file__).resolve().parents[2] / "benchmarks" / "jax_posterior.py"
_spec = importlib.util.spec_from_file_location("jax_posterior", SOURCE)
jax_posterior = importlib.util.module_from_spec(_spec)
# Dataclasses look their module up by name while the module runs.
sys.modules.setdefault("jax_posterior", jax_posterior)
_spec.loader.exec_module(jax_posterior)


class _Given:
    """A sampler that keeps what the model gives it and samples with a short Gibbs run."""

    def __init__(self):
        self.given = {}

    def sample(self, target, start, scale, rng):
        self.given = {"target": target, "start": start, "scale": scale}
        return GibbsSampler(n_chains=2, n_tune=10, n_draws=10).sample(target, start, scale, rng)


@pytest.fixture(scope="module", params=["exact, geometry sampled", "linear, geometry fixed"])
def given(request, cell, plan):
    """The posterior, start and scale that the model gives its sampler on a Table III twin campaign."""
    campaign = DigitalTwin(cell).simulate(plan, 1, np.random.default_rng(3))
    sampler = _Given()
    if request.param.startswith("exact"):
        model = ElastostaticModel.from_cell(cell, sampler=sampler)
    else:
        geometry = ElastostaticModel.from_cell(cell).geometry
        model = ElastostaticModel.from_cell(cell, GeometryPrior(geometry.mean, np.zeros((4, 4))), model="linear", sampler=sampler)
    model.fit(campaign, 0)
    return sampler.given


def test_the_log_density_is_the_packages_inside_and_outside_the_support(given):
    posterior, start, scale = given["target"], given["start"], given["scale"]
    density = jax.jit(jax_posterior.log_density(posterior))
    rng = np.random.default_rng(0)
    points = [start] + [start + 3.0 * scale * rng.standard_normal(start.size) for _ in range(8)]
    expected = np.array([posterior(x) for x in points])
    assert np.all(np.isfinite(expected))
    assert np.asarray([density(x) for x in points]) == pytest.approx(expected, abs=1e-9, rel=0)
    s0 = posterior.n_linear + 2
    for index, value in ((s0, 2.0), (s0, -0.1), (0, -start[0])):
        outside = start.copy()
        outside[index] = value
        assert posterior(outside) == -np.inf
        assert float(density(outside)) == -np.inf


def test_the_unconstrained_coordinates_start_at_the_start_with_their_jacobian(given):
    posterior, start, scale = given["target"], given["start"], given["scale"]
    coordinates = jax_posterior.Unconstrained.at(posterior, start, scale)
    origin = np.zeros(start.size)
    assert np.asarray(coordinates.theta(origin)) == pytest.approx(start, rel=1e-12)
    log_det = [float(np.linalg.slogdet(np.asarray(jax.jacfwd(coordinates.theta)(v)))[1]) for v in (origin, origin + 0.7, origin - 1.3)]
    log_jacobian = [float(coordinates.log_jacobian(v)) for v in (origin, origin + 0.7, origin - 1.3)]
    # The same up to a constant: the log of the scales.
    assert np.diff(log_det) == pytest.approx(np.diff(log_jacobian), abs=1e-9)
    assert abs(np.diff(log_jacobian)).max() > 0.1


@pytest.mark.slow
def test_nuts_and_the_collapsed_sampler_draw_the_same_posterior(given):
    """Means and the 10 % and 90 % quantiles agree within a tenth of an sd.

    Not the sd itself: log K_c has a long lower tail that the two samplers' sd estimates
    (a few thousand effective draws each) resolve only to about 10 %.
    """
    posterior, start, scale = given["target"], given["start"], given["scale"]
    nuts = jax_posterior.NutsSampler(n_chains=4, n_warmup=500, n_draws=1000)
    a = nuts.sample(posterior, start, scale, np.random.default_rng(1)).reshape(-1, posterior.ndim)
    b = CollapsedSampler().sample(posterior, start, scale, np.random.default_rng(2)).reshape(-1, posterior.ndim)
    assert nuts.record["divergences"] < 0.01 * a.shape[0]
    sd = b.std(axis=0)
    assert np.all(np.abs(a.mean(axis=0) - b.mean(axis=0)) < 0.1 * sd)
    assert np.all(np.abs(np.quantile(a, [0.1, 0.9], axis=0) - np.quantile(b, [0.1, 0.9], axis=0)) < 0.1 * sd)
