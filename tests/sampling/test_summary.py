import numpy as np
import pytest

from bayescal.errors import InputError
from bayescal.sampling.summary import diagnostics, load, parameters_json, posterior_tree, read_posterior, save, summarize
from bayescal.sampling.ensemble import EnsembleSampler


@pytest.fixture(scope="module")
def gaussian_tree():
    cov = np.array([[1.0, 0.6], [0.6, 4.0]])
    precision = np.linalg.inv(cov)
    mean = np.array([10.0, -2.0])

    def log_prob(x):
        d = x - mean
        return -0.5 * d @ precision @ d

    draws = EnsembleSampler(n_chains=4, n_tune=300, n_draws=1500).sample(
        log_prob, mean + 1.0, np.ones(2), np.random.default_rng(3)
    )
    tree = posterior_tree(
        {"a": draws[..., 0], "b": draws[..., 1], "both": draws},
        units={"a": "mm", "b": "deg", "both": "mm"},
        attrs={"seed": 3},
        dims={"both": ["axis"]},
        coords={"axis": ["x", "y"]},
    )
    return tree, mean, cov


def test_ensemble_sampler_recovers_a_correlated_gaussian(gaussian_tree):
    tree, mean, cov = gaussian_tree
    summary = summarize(tree, ["a", "b"])
    ess = summary["ess_bulk"].min()
    for i, name in enumerate(["a", "b"]):
        assert abs(summary.loc[name, "mean"] - mean[i]) < 5 * np.sqrt(cov[i, i] / ess)
        assert summary.loc[name, "sd"] == pytest.approx(np.sqrt(cov[i, i]), rel=0.1)
    assert summary.loc["a", "lo3"] == pytest.approx(summary.loc["a", "mean"] - 3 * summary.loc["a", "sd"])
    assert list(summary["unit"]) == ["mm", "deg"]


def test_diagnostics_over_independent_ensembles(gaussian_tree):
    tree, _, _ = gaussian_tree
    report = diagnostics(tree)
    assert report["n_chains"] == 4
    assert report["r_hat_max"] <= 1.01
    assert report["ess_bulk_min"] > 400


def test_vector_variables_get_one_row_per_labelled_element(gaussian_tree):
    tree, _, _ = gaussian_tree
    summary = summarize(tree, ["both"])
    assert list(summary.index) == ["both[x]", "both[y]"]
    assert summary.loc["both[x]", "mean"] == pytest.approx(summarize(tree, ["a"]).loc["a", "mean"])


def test_rhat_flags_ensembles_stuck_in_different_places():
    rng = np.random.default_rng(0)
    draws = rng.standard_normal((4, 500)) + np.array([0.0, 0.0, 0.0, 3.0])[:, None]
    tree = posterior_tree({"x": draws}, units={"x": "mm"})
    assert diagnostics(tree)["r_hat_max"] > 1.1


def test_parameters_json_and_netcdf_round_trip(gaussian_tree, tmp_path):
    tree, _, _ = gaussian_tree
    block = parameters_json(summarize(tree, ["a"]))
    assert set(block["a"]) == {"mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "unit"}
    assert block["a"]["unit"] == "mm"
    path = tmp_path / "posterior.nc"
    save(tree, path)
    again = load(path)
    assert again.attrs["seed"] == 3
    assert again["posterior"]["b"].attrs["units"] == "deg"
    assert summarize(again).equals(summarize(tree))


def test_read_posterior_gives_the_draws_or_names_the_file(gaussian_tree, tmp_path):
    tree, _, _ = gaussian_tree
    path = tmp_path / "posterior.nc"
    save(tree, path)
    again, posterior = read_posterior(path)
    np.testing.assert_array_equal(posterior["a"].values, tree["posterior"]["a"].values)
    assert again.attrs["seed"] == 3
    text = tmp_path / "posterior.csv"
    text.write_text("a,b\n1,2\n")
    with pytest.raises(InputError, match="cannot read a geometry posterior") as error:
        read_posterior(text, "a geometry posterior")
    assert error.value.source == str(text)
    with pytest.raises(InputError, match="cannot read a posterior DataTree"):
        read_posterior(tmp_path / "absent.nc")


def test_every_variable_needs_a_unit():
    with pytest.raises(ValueError, match="no unit given for x"):
        posterior_tree({"x": np.zeros((2, 10))}, units={})


def test_sampler_rejects_a_start_outside_the_support():
    sampler = EnsembleSampler(n_chains=1, n_tune=1, n_draws=1)
    with pytest.raises(ValueError, match="not finite at the starting point"):
        sampler.sample(lambda x: -np.inf, np.zeros(1), np.ones(1), np.random.default_rng(0))


def test_same_seed_same_draws():
    sampler = EnsembleSampler(n_chains=2, n_tune=10, n_draws=20)
    log_prob = lambda x: -0.5 * float(x @ x)  # noqa: E731
    first = sampler.sample(log_prob, np.zeros(3), np.ones(3), np.random.default_rng(7))
    second = sampler.sample(log_prob, np.zeros(3), np.ones(3), np.random.default_rng(7))
    np.testing.assert_array_equal(first, second)


def test_unconverged_posteriors_are_warned_about():
    from bayescal.sampling.summary import ConvergenceWarning, warn_if_unconverged

    good = {"r_hat_max": 1.002, "ess_bulk_min": 2000.0, "ess_tail_min": 1500.0}
    warn_if_unconverged(good, what="x")  # silent
    with pytest.warns(ConvergenceWarning, match=r"the test posterior may not have converged \(R-hat 1.050 > 1.01, tail ESS 90 < 400\)"):
        warn_if_unconverged(good | {"r_hat_max": 1.05, "ess_tail_min": 90.0}, what="the test posterior")


def test_summary_gives_the_central_interval_beside_mean_plus_minus_3_sd():
    rng = np.random.default_rng(3)
    skewed = rng.exponential(size=(4, 20000))
    summary = summarize(posterior_tree({"x": skewed}, units={"x": "1"}))
    row = summary.loc["x"]
    # An exponential posterior: mean - 3 sd is negative, its 0.135 % quantile is not.
    assert row["lo3"] < 0 < row["q_lo3"]
    assert row["q_lo3"] == pytest.approx(-np.log(1 - 0.00135), rel=0.2)
    assert row["q_hi3"] == pytest.approx(-np.log(0.00135), rel=0.05)
    assert set(parameters_json(summary)["x"]) == {"mean", "sd", "lo3", "hi3", "q_lo3", "q_hi3", "unit"}


def test_converged_needs_rhat_and_both_effective_sizes():
    from bayescal.sampling.summary import ESS_LIMIT, R_HAT_LIMIT, converged

    good = {"r_hat_max": R_HAT_LIMIT, "ess_bulk_min": ESS_LIMIT, "ess_tail_min": ESS_LIMIT}
    assert converged(good)
    assert not converged(good | {"r_hat_max": R_HAT_LIMIT + 0.001})
    assert not converged(good | {"ess_tail_min": ESS_LIMIT - 1})
    assert not converged(good | {"r_hat_max": float("nan")})


def test_a_sampler_that_falls_short_hands_over_to_its_extension_and_the_result_names_it():
    from dataclasses import dataclass

    from bayescal.sampling.summary import sample_until_converged

    @dataclass(frozen=True)
    class Stuck:
        n_draws: int = 500

        def draws(self, rng):
            # every chain held at its own place: R-hat far above 1.01 however long the chains
            return rng.normal(size=(4, self.n_draws)) * 0.01 + np.arange(4)[:, None]

        def extended(self):
            return Mixing(self.n_draws)

    @dataclass(frozen=True)
    class Mixing(Stuck):
        def draws(self, rng):
            return rng.normal(size=(4, self.n_draws))

    rng = np.random.default_rng(0)
    run = lambda sampler: (posterior_tree({"x": sampler.draws(rng)}, units={"x": "1"}),)  # noqa: E731
    with pytest.warns(UserWarning, match=r"sampled again \(Mixing, 500 draws per chain\)"):
        (tree,), summary, used = sample_until_converged(run, Stuck(), 1, what="the test posterior")
    assert used == Mixing(500) and summary.loc["x", "r_hat"] < 1.01
    # without an extension allowed, the stuck draws are returned as they are, and nothing is said of extending
    (tree,), summary, used = sample_until_converged(run, Stuck(), 0, what="the test posterior")
    assert used == Stuck() and summary.loc["x", "r_hat"] > 1.5


def test_a_sampler_without_an_extension_doubles_its_draws():
    from dataclasses import dataclass

    from bayescal.sampling.summary import sample_until_converged

    @dataclass(frozen=True)
    class Short:
        n_draws: int = 25

    rng = np.random.default_rng(1)
    run = lambda sampler: (posterior_tree({"x": rng.normal(size=(4, sampler.n_draws))}, units={"x": "1"}),)  # noqa: E731
    with pytest.warns(UserWarning, match=r"sampled again \(Short, 100 draws per chain\)"):
        _, _, used = sample_until_converged(run, Short(), 2, what="the test posterior")
    assert used == Short(100)


def test_read_posterior_of_refuses_the_other_kind_a_missing_variable_and_non_finite_draws(gaussian_tree, tmp_path):
    from bayescal.sampling.summary import read_posterior_of

    tree, _, _ = gaussian_tree
    path = tmp_path / "posterior.nc"
    save(tree, path)
    assert read_posterior_of(str(path), "--thing", needs=("a",), foreign="z", other="--other").attrs["seed"] == 3
    with pytest.raises(InputError, match=r"no variable 'q': is it the file --thing expects\?"):
        read_posterior_of(str(path), "--thing", needs=("a", "q"), foreign="z", other="--other")
    with pytest.raises(InputError, match=r"the variable 'b' of a --other posterior: is it the file --thing expects\?"):
        read_posterior_of(str(path), "--thing", needs=("a",), foreign="b", other="--other")
    draws = np.ones((2, 50))
    draws[1, 7] = np.nan
    save(posterior_tree({"a": draws}, units={"a": "mm"}), tmp_path / "nan.nc")
    with pytest.raises(InputError, match="1 non-finite draws") as error:
        read_posterior_of(str(tmp_path / "nan.nc"), "--thing", needs=("a",), foreign="z", other="--other")
    assert error.value.column == "a"


def test_a_pooled_posterior_mixes_its_fits_and_judges_convergence_within_each():
    from bayescal.sampling.summary import COMPONENT, pooled_tree

    rng = np.random.default_rng(8)
    # two fits whose posteriors differ by 5 sd (a correction's draws apart), one with twice the draws and more chains
    first = posterior_tree({"k": rng.normal(0.0, 1.0, size=(4, 400))}, units={"k": "mm"}, attrs={"sampler": "a"})
    second = posterior_tree({"k": rng.normal(5.0, 1.0, size=(6, 800))}, units={"k": "mm"}, attrs={"sampler": "b"})
    tree = pooled_tree([first, second])
    posterior = tree["posterior"]
    assert posterior.sizes["chain"] == 8 and posterior.sizes["draw"] == 400 and tree.attrs["sampler"] == "a"
    assert list(posterior[COMPONENT].values) == [0] * 4 + [1] * 4
    summary = summarize(tree)
    # the mixture: mean halfway, variance the within plus the between (1 + 2.5²)
    assert summary.loc["k", "mean"] == pytest.approx(2.5, abs=0.1)
    assert summary.loc["k", "sd"] == pytest.approx(np.sqrt(1 + 2.5**2), rel=0.05)
    # each fit converged: R-hat near 1 and the ESS the sum of both, where the chains taken as one fit would fail
    assert summary.loc["k", "r_hat"] < 1.01 and summary.loc["k", "ess_bulk"] > 2000
    plain = posterior.to_dataset().drop_vars(COMPONENT)
    assert summarize(xr_tree(plain)).loc["k", "r_hat"] > 1.5


def xr_tree(dataset):
    import xarray as xr

    return xr.DataTree.from_dict({"posterior": dataset})
