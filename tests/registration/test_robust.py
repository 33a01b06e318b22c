"""The covariance clustered by swept angle: its degrees of freedom and the Student-t intervals they give."""

import numpy as np
import pytest
from scipy.stats import t

from bayescal.registration.robust import clustered_covariance, combined_dof, interval_factor, sandwich_dof


def _mean_over_clusters(rng, clusters, size):
    """A mean fitted over ``clusters`` balanced clusters of ``size`` readings of three coordinates each."""
    jac = np.ones((clusters * size * 3, 1))
    residual = rng.normal(size=jac.shape[0])
    residual -= residual.mean()
    return clustered_covariance(jac, residual, np.linalg.inv(jac.T @ jac), np.repeat(np.arange(clusters), size))


@pytest.mark.parametrize("clusters", [3, 6, 12])
def test_a_mean_over_balanced_clusters_has_one_degree_of_freedom_fewer_than_them(clusters):
    _, kernel = _mean_over_clusters(np.random.default_rng(clusters), clusters, 4)
    assert sandwich_dof(kernel, np.ones(1)) == pytest.approx(clusters - 1)


def test_the_sandwich_of_a_mean_is_the_variance_of_its_cluster_means():
    # Bell and McCaffrey's correction for a balanced mean: the textbook s² / G of the G cluster means.
    rng = np.random.default_rng(3)
    clusters, size = 6, 4
    cov, _ = _mean_over_clusters(rng, clusters, size)
    rng = np.random.default_rng(3)
    residual = rng.normal(size=clusters * size * 3)
    residual -= residual.mean()
    means = residual.reshape(clusters, size * 3).mean(axis=1)
    assert cov[0, 0] == pytest.approx(np.var(means, ddof=1) / clusters)


def test_intervals_are_student_t_at_the_normals_coverage():
    # With 4 degrees of freedom the interval covering as the normal's ±3 sd is ±6.62 sd, not ±3.
    assert interval_factor(3, 4.0) == pytest.approx(t.ppf(0.99865, 4), rel=1e-3) == pytest.approx(6.62, abs=0.01)
    assert interval_factor(1, 4.0) == pytest.approx(1.14, abs=0.01)
    assert np.all(interval_factor(2, np.array([np.inf, 1e6])) == pytest.approx(2.0, abs=1e-5))


def test_a_known_floor_adds_degrees_of_freedom_and_independent_parts_add_theirs():
    assert combined_dof(1.0, [(1.0, 4.0)]) == pytest.approx(4.0)
    # Half the variance known exactly: its relative noise halves, and its degrees of freedom quadruple.
    assert combined_dof(2.0, [(1.0, 4.0)]) == pytest.approx(16.0)
    assert combined_dof(2.0, [(1.0, 4.0), (1.0, 4.0)]) == pytest.approx(8.0)
    assert combined_dof(1.0, [(0.0, 4.0)]) == np.inf
