"""The tracker's drift measured from reference nests and repeats, and the compliances after its removal, on planted drifts (slow)."""

import numpy as np
import pytest

from bayescal_studies.studies.nest_drift import nest_drift_coverage

NOMINAL = np.array([0.6827, 0.9545, 0.9973])
"""Probability of a normal variable within 1, 2 and 3 sd."""


def coverage(table, prefix: str) -> np.ndarray:
    """Fractions of the compliances' errors within 1, 2 and 3 posterior sd, over every campaign and compliance."""
    z = np.abs(table.filter(like=prefix).to_numpy(dtype=float).ravel())
    z = z[np.isfinite(z)]
    return np.array([np.mean(z <= k) for k in (1, 2, 3)]), z.size


@pytest.mark.slow
@pytest.mark.parametrize(
    ("generator", "evidence", "magnitude", "n_draws", "kind"),
    [
        ("twin", "nests", 1.0, 0, "removed"),
        ("independent", "nests", 1.0, 0, "removed"),
        # at three times the default the per-row variance undercovers on the twin (docs/critique.md): integrated
        ("twin", "nests", 3.0, 4, "integrated"),
        ("independent", "nests", 3.0, 4, "integrated"),
        ("twin", "repeats", 3.0, 4, "integrated"),
    ],
)
def test_drift_is_measured_within_its_sd_and_the_compliances_cover_after_its_removal(data_dir, generator, evidence, magnitude,
                                                                                    n_draws, kind):
    table = nest_drift_coverage(data_dir / "kr270.toml", (magnitude,), n_seeds=100, generator=generator, evidence=evidence,
                                n_draws=n_draws, plan_path=data_dir / "table3_plan.csv")
    # the drift at every reading and in every deflection, each coordinate, within its own 3 sd
    assert table["reading_within_3sd"].mean() >= 0.95 and table["deflection_within_3sd"].mean() >= 0.95
    rates, n = coverage(table, f"{kind}_z_")
    # the compliances' errors within their 1, 2, 3 sd as often as a normal's, to four binomial sd
    tolerance = 4 * np.sqrt(NOMINAL * (1 - NOMINAL) / n) + 1.0 / n
    assert np.all(np.abs(rates - NOMINAL) <= tolerance), (rates, tolerance)


@pytest.mark.slow
def test_calibrate_integrated_over_its_default_drift_draws_covers_at_two_sd(data_dir):
    """The twin at three times its default drift (0.6 mm/h), measured from nests and repeats (``calibrate --nests
    --drift-from-repeats``), the calibration integrated over ``calibrate``'s default number of draws: the compliances
    within 2 posterior sd as often as a normal's, to 2 binomial sd, over 60 campaigns (300 errors)."""
    from bayescal.cli.calibrate import DRIFT_DRAWS

    table = nest_drift_coverage(data_dir / "kr270.toml", (3.0,), n_seeds=60, generator="twin", evidence="both",
                                n_draws=DRIFT_DRAWS, plan_path=data_dir / "table3_plan.csv")
    rates, n = coverage(table, "integrated_z_")
    tolerance = 2 * np.sqrt(NOMINAL[1] * (1 - NOMINAL[1]) / n)
    assert n >= 300 and abs(rates[1] - NOMINAL[1]) <= tolerance, (rates, tolerance)
