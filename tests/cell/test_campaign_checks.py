"""Tests of bayescal.cell.campaign_checks: a campaign's plausibility against its cell."""

from __future__ import annotations

import numpy as np
import pytest

from bayescal.cell.campaign_checks import check_deflection
from bayescal.errors import InputError


def _elastic_rows(rng, n: int, noise_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Wrenches and positions of ``n`` rows whose markers move by ``C f`` plus noise, with ``C`` a random
    symmetric positive definite compliance (m/N) per row: an elastic arm written apart from the twin."""
    force = rng.normal(size=(n, 3)) * rng.uniform(500, 3000, size=(n, 1))
    wrench = np.hstack([force, rng.normal(size=(n, 3)) * 100])
    a = rng.normal(size=(n, 3, 3))
    compliance = (np.einsum("nij,nkj->nik", a, a) + 0.1 * np.eye(3)) * 1e-6
    p0 = rng.uniform(-2, 2, size=(n, 3))
    p1 = p0 + np.einsum("nij,nj->ni", compliance, force) + rng.normal(scale=noise_m, size=(n, 3))
    return wrench, np.hstack([p0, p1])


@pytest.mark.parametrize("seed", range(5))
def test_check_deflection_accepts_elastic_rows_and_refuses_them_swapped_or_with_the_wrench_flipped(seed):
    rng = np.random.default_rng(seed)
    wrench, positions = _elastic_rows(rng, 30, 40e-6)
    lines = np.arange(2, 32)
    check_deflection(wrench, positions, lines, "c.csv")
    for hostile in ((-wrench, positions), (wrench, positions[:, [3, 4, 5, 0, 1, 2]])):
        with pytest.raises(InputError, match=r"^c\.csv:\d+, column 'x1_mm': the markers move against the load force"):
            check_deflection(*hostile, lines, "c.csv")
    with pytest.raises(InputError, match="every wrench fx_N..mz_Nm is zero"):
        check_deflection(0 * wrench, positions, lines, "c.csv")


def test_check_deflection_rarely_refuses_loads_lost_in_the_noise():
    rng = np.random.default_rng(7)
    refused = 0
    for _ in range(400):
        wrench, positions = _elastic_rows(rng, 20, 1.0)  # 1 m of noise: the deflection is invisible
        try:
            check_deflection(wrench, positions, np.arange(20), "c.csv")
        except InputError:
            refused += 1
    # DEFLECTION_Z = 3 refuses pure noise at about 0.13 %: 0.5 expected refusals of 400.
    assert refused <= 4
