"""The words of the review page: a one-line explanation of every diagnostic, and words for raw keys.

:data:`TERMS` is the page's glossary: wherever one of its terms appears in a
paragraph, a list or a table's header, the page gives it a hover title, and
the page ends with the terms it used (``docs/glossary.md`` says the same at
length).  :data:`LABELS` turns the keys of the JSON files a report is given
(``delta_elpd``…) into the words a person reads;
the JSON written beside the page keeps the keys.
"""

from __future__ import annotations

from bayescal.robot.kinds import LAWS

__all__ = ["TERMS", "LABELS", "label"]

TERMS = {
    "±3σ": "Posterior mean ± 3 posterior sd, as in the paper's Table IV; for a normal posterior it holds 99.73 % of the probability.",
    "sd": "Posterior standard deviation: the uncertainty of the value from these data.",
    "χ²/dof": "Squared residuals over the tracker's noise variance, per degree of freedom: 1 when the residuals are as large "
    "as the stated noise, well above 1 when the model or the noise figure misses something.",
    "R-hat": "Rank-normalised split R-hat (Vehtari et al. 2021): 1 when the chains agree; above 1.01 the chains have not mixed.",
    "bulk ESS": "Effective sample size for the mean and centre of the posterior: how many independent draws the correlated "
    "chains are worth; at least 400 wanted.",
    "tail ESS": "Effective sample size for the 5 % and 95 % quantiles, which set the ±3σ intervals; at least 400 wanted.",
    "rank": "Number of independent combinations of compliances the campaign's design (eq 30) can measure; a parameter "
    "outside them is structurally not identifiable.",
    "condition number": "Largest over smallest eigenvalue of the design's information with unit-length columns: how nearly "
    "the columns repeat each other (above 10⁴: ill-conditioned).",
    "not identifiable": "The campaign cannot tell this parameter: structurally (no load excites it) or from these data (its "
    "interval reaches 0 or its posterior is mostly the prior); it keeps the cell's value.",
    "ρ0": "A plan's predicted root-mean-square error left at the test pose after compensation (eq 38), linearised at the "
    "design: the plan's covariance carried to the test pose, plus the prior of each compliance the plan does not excite.",
    "everything counted": "The error left over the calibration's draws with every parameter's uncertainty in it: the "
    "posterior's, and the cell's prior ([joints] k_log_sd) for a compliance the campaign cannot identify.",
    "identified parameters only": "The same error with the parameters the campaign cannot identify held at the value the "
    "correction applies: the part a better campaign of the same kind could reduce.",
    "99.73 %": "Quantile over the posterior draws: 99.73 % of the draws leave a smaller error (the 3σ level of a normal).",
    "lack of fit": "The scatter of the configuration means about the model against the scatter of the repeats (F test); "
    "a p-value below 0.01 says the model misses an effect.",
    "ΔELPD": "Gain in expected log predictive density of held-out configurations over the calibrated model, in nats; "
    "positive: the candidate predicts unseen data better.",
    "nats": "Natural-log units of predictive density: 1 nat is a factor e (2.7) in the probability of the held-out data.",
    "SE": "Standard error of ΔELPD over the held-out configurations; a cause is named when ΔELPD > 2 SE and > 4 nats, or > 25 nats and > 1 SE, or > 1 SE and > 4 nats where the repeats show a misfit no cause passes for and are fitted with it.",
    "η(q2)": "The compensator's torque factor of eq 9: how the spring's torque on joint 2 varies with its angle.",
    "K_c": "The compensator spring's stiffness (N/mm); it cannot be negative.",
    "s0": "The compensator spring's free length (mm).",
    "Table IV": "The identified compliances and spring, with ±3σ, that Klimchik et al. publish for their KR-270.",
    "Table II": "The compensator geometry, with ±3σ, that Klimchik et al. publish.",
}
"""Term → one-line explanation; the page marks each term with a hover title and lists those it used."""
# Every other compensator law's parameters, in its own words (the spring's are above).
TERMS |= {p.name: f"{p.description[0].upper()}{p.description[1:]} ({p.unit})." for law in LAWS.values() for p in law.PARAMETERS if p.name not in TERMS}


LABELS = {
    "rms": "rms over the draws",
    "q95": "95 % of draws below",
    "q99.73": "99.73 % of draws below",
    "mean": "mean",
    "sd": "sd",
    "lo3": "mean − 3 sd",
    "hi3": "mean + 3 sd",
    "r_hat_max": "R-hat (largest)",
    "ess_bulk_min": "bulk ESS (smallest)",
    "ess_tail_min": "tail ESS (smallest)",
    "n_chains": "chains",
    "n_draws": "draws per chain",
    "sampler": "sampler",
    "delta_elpd": "ΔELPD [nats]",
    "se": "SE [nats]",
    "n_configs": "held-out configurations",
    "step": "step",
    "named": "named as a cause",
    "meaning": "what it is",
    "width_3sd": "±3σ",
    "width_3sd_pct": "±3σ [% of value]",
    "excited": "excited by the plan",
    "value": "value",
    "unit": "unit",
    "residual_um": "residual [μm]",
    "normalised": "residual / tracker sd",
    "q2_deg": "q2 [deg]",
    "config": "configuration",
    "repeat": "repeat",
    "marker": "marker",
    "log_det_information": "log det of the information matrix",
    "criterion_value": "value of the optimised criterion (SI)",
    "search_model": "model of the search",
}
"""Raw key of a results file → the words shown on the page."""


def label(key: str) -> str:
    """The words for ``key``: its :data:`LABELS` entry, else the key with underscores as spaces."""
    return LABELS.get(key, key.replace("_", " "))
