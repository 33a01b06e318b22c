import math

import numpy as np
import pytest
from scipy.special import gammainc, gammaincc, gammaln

from bayescal.sampling import summary as posterior
from bayescal.geometry.circle import known_angle_crb
from bayescal.geometry.arcs import CompensatorGeometryModel, MarkerLayout, MarkerPoints, read_arc_points
from bayescal.geometry.density import _Density, _inner_range, _log_gamma_mass, _regularized_gamma, _truncated_gamma
from bayescal.geometry.posterior import GeometryPosteriorModel, GeometryPriors, geometry_sampler
from bayescal.reference import read_paper_reference
from bayescal_studies.studies.arc_fit import TABLE_I_NOISE
from bayescal_studies.studies.geometry_coverage import coverage_study
from bayescal.twin.arcs import simulate_markers
from bayescal.units import DEG, MM

Q2 = np.array([-0.01, -30, -60, -90, -120, -145]) * DEG


@pytest.fixture(scope="module")
def table1(data_dir):
    return read_arc_points(data_dir / "table1_geometry.csv")


@pytest.fixture(scope="module")
def table1_posterior(table1):
    # The default settings, as `bayescal geometry` uses them.
    return GeometryPosteriorModel().fit(table1, rng=0)


def light(model="concentric"):
    return GeometryPosteriorModel(model, sampler=geometry_sampler(n_chains=2, n_tune=300, n_draws=200))


def test_table1_meets_the_paper_and_converges(table1_posterior, data_dir):
    summary = table1_posterior.summary()
    reference = read_paper_reference(data_dir / "paper_reference.csv")
    assert abs(summary.loc["L", "mean"] - 184.72) < 0.03
    assert abs(summary.loc["a_x", "mean"] - reference.loc["a_x", "value"]) <= reference.loc["a_x", "ci3"]
    # a_y differs from Table II by more than the paper's interval but stays inside ours.
    assert abs(summary.loc["a_y", "mean"] - reference.loc["a_y", "value"]) <= 3 * summary.loc["a_y", "sd"]
    assert table1_posterior.diagnostics()["r_hat_max"] <= 1.01
    assert table1_posterior.diagnostics()["ess_bulk_min"] >= 1000
    assert table1_posterior.diagnostics()["n_chains"] == 4


def test_summary_rows_and_units(table1_posterior):
    summary = table1_posterior.summary()
    expected = {"L", "a_x", "a_y", "phi", "alpha", "p2_x", "p2_y", "p0_x", "p0_y", "R[P01]", "R[P02]", "sigma[lever]", "sigma[cylinder]"}
    assert set(summary.index) == expected
    assert summary.loc["phi", "unit"] == "deg"
    assert summary.loc["R[P01]", "unit"] == "mm"


def test_lever_block_matches_the_exact_student_t_posterior(table1, table1_posterior):
    # The lever marker's model is linear in (p2, L·cos phi, L·sin phi); with σ integrated out
    # under a log-uniform prior its posterior is a Student t with n - 4 degrees of freedom.
    fit = CompensatorGeometryModel().fit(table1).lever
    rss = np.sum(fit.residuals**2)
    nu = fit.residuals.size - 4
    cov = nu / (nu - 2) * rss / nu * known_angle_crb(table1.of("P1")[0], fit.radius, fit.phi, 1.0, fit.sense)
    summary = table1_posterior.summary()
    exact = {
        "p2_x": (fit.centre[0] / MM, math.sqrt(cov[0, 0]) / MM),
        "p2_y": (fit.centre[1] / MM, math.sqrt(cov[1, 1]) / MM),
        "L": (fit.radius / MM, math.sqrt(cov[2, 2]) / MM),
        "phi": (fit.phi / DEG, math.sqrt(cov[3, 3]) / DEG),
    }
    mean_sigma = math.sqrt(rss / 2) * math.exp(gammaln((nu - 1) / 2) - gammaln(nu / 2)) / MM
    sd_sigma = math.sqrt(rss / (nu - 2) / MM**2 - mean_sigma**2)
    exact["sigma[lever]"] = (mean_sigma, sd_sigma)
    for name, (mean, sd) in exact.items():
        row = summary.loc[name]
        assert abs(row["mean"] - mean) < 5 * sd / math.sqrt(row["ess_bulk"]), name
        assert row["sd"] == pytest.approx(sd, rel=0.1), name


def test_residuals_at_the_posterior_mean(table1_posterior):
    rms = table1_posterior.residuals_rms
    assert set(rms) == {"P1", "P01", "P02"}
    assert table1_posterior.residuals["P1"].shape == (6, 2)
    assert table1_posterior.residuals["P01"].shape == (6,)
    assert rms["P1"] == pytest.approx(table1_posterior.closed_form.residuals_rms["P1"], rel=0.05)


def test_posterior_round_trips_through_netcdf(table1_posterior, tmp_path):
    path = tmp_path / "geometry.nc"
    table1_posterior.save(path)
    tree = posterior.load(path)
    assert tree["posterior"]["L"].attrs["units"] == "mm"
    assert tree["posterior"]["phi"].attrs["units"] == "deg"
    np.testing.assert_allclose(tree["posterior"]["a_y"].values, table1_posterior.tree["posterior"]["a_y"].values)
    assert list(tree["posterior"]["sigma"].coords["noise_group"].values) == ["lever", "cylinder"]
    assert tree["observed_data"]["x_mm"].size == 18


def test_same_seed_same_draws(table1):
    first = light().fit(table1, rng=5).tree["posterior"]["a_x"].values
    second = light().fit(table1, rng=5).tree["posterior"]["a_x"].values
    np.testing.assert_array_equal(first, second)


def test_rigid_model_recovers_a_simulated_rigid_layout(table1):
    layout = MarkerLayout.from_fit(CompensatorGeometryModel().fit(table1), table1)
    points = simulate_markers(layout, Q2, np.random.default_rng(11), sigma=TABLE_I_NOISE)
    result = light("rigid").fit(points, rng=3)
    summary = result.summary()
    truth = {"L": layout.L / MM, "a_x": (layout.p2 - layout.p0)[0] / MM, "a_y": (layout.p2 - layout.p0)[1] / MM}
    for name, value in truth.items():
        assert summary.loc[name, "lo3"] <= value <= summary.loc[name, "hi3"], name
    # Knowing the cylinder's direction pins p0 far better than the concentric model.
    concentric = light().fit(points, rng=3).summary()
    assert summary.loc["a_x", "sd"] < concentric.loc["a_x", "sd"] / 2
    assert {"delta[P01]", "delta[P02]"} <= set(summary.index)


def test_rigid_model_misfits_table1_more_than_the_concentric_one(table1, table1_posterior):
    rigid = light("rigid").fit(table1, rng=2)
    assert rigid.residuals["P01"].shape == (6, 2)
    assert rigid.summary().loc["sigma[cylinder]", "mean"] > table1_posterior.summary().loc["sigma[cylinder]", "mean"]


def test_a_mirrored_frame_gives_the_same_geometry(table1, table1_posterior):
    mirrored = MarkerPoints.from_arrays(table1.marker, table1.q2, table1.xyz * np.array([1.0, -1.0]))
    with pytest.warns(UserWarning):
        summary = light().fit(mirrored, rng=1).summary()
    reference = table1_posterior.summary()
    for name in ("a_y", "phi", "alpha"):
        assert abs(summary.loc[name, "mean"] - reference.loc[name, "mean"]) < 4 * reference.loc[name, "sd"], name


def test_3d_points_use_x_and_y(table1):
    xyz = np.column_stack([table1.xyz, np.full(len(table1.marker), 0.3)])
    points = MarkerPoints.from_arrays(table1.marker, table1.q2, xyz)
    result = light().fit(points, rng=0)
    assert result.closed_form.lever.centre.shape == (2,)
    assert abs(result.summary().loc["L", "mean"] - 184.72) < 0.05


def test_intervals_cover_simulated_truth(table1):
    # A coarse default check (it fails if the sd is off by a factor of 2); the slow test below
    # repeats it with many campaigns and a binomial tolerance.
    layout = MarkerLayout.from_fit(CompensatorGeometryModel().fit(table1), table1)
    model = GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=200, n_draws=150))
    n_rep = 16
    study = coverage_study(layout, Q2, TABLE_I_NOISE, n_rep, model, np.random.default_rng(2024))
    names = ["L", "a_x", "a_y"]
    assert abs(study.loc[names, "covered_1"].mean() - study.loc[names, "content_1"].mean()) < 0.2
    assert np.sum((1 - study.loc[names, "covered_3"]) * n_rep) <= 3


@pytest.mark.slow
def test_intervals_cover_at_their_posterior_content(table1):
    layout = MarkerLayout.from_fit(CompensatorGeometryModel().fit(table1), table1)
    n_rep = 300
    model = GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=400, n_draws=400))
    study = coverage_study(layout, Q2, TABLE_I_NOISE, n_rep, model, np.random.default_rng(7))
    for name in ("L", "a_x", "a_y", "p2_x", "p2_y", "p0_x", "p0_y", "phi"):
        for k in (1, 2, 3):
            rate = study.loc[name, f"content_{k}"]
            error = math.sqrt(rate * (1 - rate) / n_rep)
            assert abs(study.loc[name, f"covered_{k}"] - rate) < max(3.5 * error, 1.5 / n_rep), (name, k)


def test_z_coordinates_are_announced_as_unused_by_the_planar_posterior(table1):
    with_z = MarkerPoints(
        table1.marker, table1.q2, np.column_stack([table1.xyz, np.full(len(table1.q2), 0.05)]), table1.line, "z.csv"
    )
    model = GeometryPosteriorModel(sampler=geometry_sampler(n_chains=2, n_tune=50, n_draws=50))
    with pytest.warns(UserWarning, match=r"z.csv: the posterior uses x and y only .* 0.00 deg from Z"):
        fit = model.fit(with_z, rng=0)
    assert fit.summary().loc["L", "mean"] == pytest.approx(184.72, abs=0.1)


@pytest.mark.parametrize("model", ["concentric", "rigid"])
def test_the_density_of_a_batch_is_that_of_each_vector(table1, model):
    density = _Density(table1, CompensatorGeometryModel().fit(table1), model, GeometryPriors())
    start = density.start()
    batch = start + density.scale(start) * np.random.default_rng(0).standard_normal((2, 3, start.size))
    batch[0, 0, 2] = -1.0  # a negative L: outside the support
    values = density(batch)
    assert values.shape == (2, 3)
    assert values[0, 0] == -math.inf
    np.testing.assert_allclose(values.ravel()[1:], [density(theta) for theta in batch.reshape(-1, start.size)[1:]], rtol=1e-13)


@pytest.mark.parametrize("a", [0.5, 1.5, 6.0, 12.0, 60.5])
def test_incomplete_gamma_agrees_with_scipy_at_every_scale(a):
    x = np.r_[0.0, np.geomspace(1e-8, 1e5, 200), a]
    p, q = _regularized_gamma(a, x)
    small = x < a
    np.testing.assert_allclose(p[small], gammainc(a, x[small]), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(q[~small], gammaincc(a, x[~small]), rtol=1e-12, atol=1e-300)
    lo, hi = 1e-8 * x[1:], x[1:]
    exact = gammainc(a, hi) - gammainc(a, lo)
    finite = exact > 0
    np.testing.assert_allclose(_log_gamma_mass(a, lo, hi)[finite], np.log(exact[finite]), rtol=1e-12, atol=1e-13)


@pytest.mark.parametrize("share", [1e-17, 0.5])
def test_inner_range_leaves_less_than_its_share_outside(share):
    for a in (1.5, 6.0, 12.0, 100.0):
        lo, hi = _inner_range(a, share)
        assert 0 < gammainc(a, lo) + gammaincc(a, hi) < share


@pytest.mark.parametrize("lo, hi", [(2.0, 9.0), (5.0, 6.0)])
def test_truncated_gamma_draws_have_the_truncated_mean(lo, hi):
    # (2, 9) is drawn by rejection, (5, 6) (most of the mass outside) by inverting the CDF.
    a, n = 6.0, 20000
    draws = _truncated_gamma(np.array([a]), np.full((n, 1), lo), np.full((n, 1), hi), np.random.default_rng(4))
    assert lo <= draws.min() and draws.max() <= hi
    mass = gammainc(a, hi) - gammainc(a, lo)
    mean = a * (gammainc(a + 1, hi) - gammainc(a + 1, lo)) / mass
    second = a * (a + 1) * (gammainc(a + 2, hi) - gammainc(a + 2, lo)) / mass
    assert abs(draws.mean() - mean) < 4 * math.sqrt((second - mean**2) / n)


def test_emcee_ensembles_sample_the_same_posterior(table1, table1_posterior):
    ensembles = GeometryPosteriorModel(sampler=geometry_sampler("emcee", n_chains=2, n_tune=200, n_draws=100)).fit(table1, rng=1)
    assert ensembles.tree.attrs["sampler"].startswith("emcee, 2 independent ensembles")
    assert table1_posterior.tree.attrs["sampler"].startswith("independence Metropolis-Hastings")
    summary, reference = ensembles.summary(), table1_posterior.summary()
    for name in ("L", "a_x", "a_y", "phi"):
        assert abs(summary.loc[name, "mean"] - reference.loc[name, "mean"]) < 0.3 * reference.loc[name, "sd"], name
        assert summary.loc[name, "sd"] == pytest.approx(reference.loc[name, "sd"], rel=0.25), name


def test_geometry_sampler_names_the_independence_and_the_emcee_samplers_with_the_same_arguments():
    from bayescal.sampling.ensemble import EnsembleSampler
    from bayescal.sampling.independence import IndependenceSampler

    default, ensembles = geometry_sampler(), geometry_sampler("emcee")
    assert isinstance(default, IndependenceSampler) and isinstance(ensembles, EnsembleSampler)
    assert (default.n_chains, default.n_tune, default.n_draws) == (4, 200, 1000)
    assert (ensembles.n_chains, ensembles.n_tune, ensembles.n_draws) == (4, 1000, 1000)
    short = geometry_sampler("emcee", n_chains=2, n_tune=30, n_draws=50)
    assert (short.n_chains, short.n_tune, short.n_draws) == (2, 30, 50)
    with pytest.raises(ValueError, match="independence"):
        geometry_sampler("gibbs")
