"""What a technician does next, derived from a calibration's results: one or two sentences.

The advice follows from the numbers, never from the campaign's name: convergence
first (an unconverged posterior says nothing), then lack of fit against the
repeats (the model misses an effect), then identifiability (what the campaign
cannot tell), then whether the test pose's error left is small enough to use.
"""

from __future__ import annotations

from collections.abc import Sequence

from bayescal.numbers import error_length

from bayescal.inference.lack_of_fit import LACK_OF_FIT_LEVEL

__all__ = ["calibration_next_steps", "critique_next_steps"]


def calibration_next_steps(
    diagnostics: dict, not_identifiable: list[str], error_q9973_mm: float | None, converged: bool, cell_limited: list[str] = ()
) -> str:
    """One or two sentences on what to do with a calibration.

    Parameters
    ----------
    diagnostics : dict
        The results' ``diagnostics()`` (model name, ``lack_of_fit`` block or None).
    not_identifiable : list of str
        Parameters the campaign cannot identify (structurally or from the data).
    error_q9973_mm : float or None
        99.73 % quantile of the test pose's error left after compensation (mm), None when not predicted.
    converged : bool
        Whether R-hat and both ESS meet the sampler's thresholds.
    cell_limited : list of str
        Those of ``not_identifiable`` that no campaign of this cell can identify (k1 on a cell that
        hangs masses only): re-measuring would not help, so the advice says so rather than send to a plan.
    """
    if not converged:
        return "Next: run again with more --draws (or another --seed); until R-hat and the bulk and tail ESS meet their limits, do not use these numbers."
    lack = diagnostics.get("lack_of_fit")
    if lack is not None and lack["p_value"] is not None and lack["p_value"] < LACK_OF_FIT_LEVEL:
        other = "exact" if diagnostics.get("model") == "linear" else "linear"
        return (
            f"Next: the model misses an effect the repeats show (scatter {lack['factor']:.1f} times the repeats'); "
            f"run `bayescal critique` on this campaign to name its cause, compare with --model {other}, "
            "and do not compensate with this result until the cause is found."
        )
    steps = []
    limited = [name for name in not_identifiable if name in cell_limited]
    others = [name for name in not_identifiable if name not in cell_limited]
    if others:
        steps.append(
            f"{', '.join(others)} cannot be told from this campaign: the error bounds carry their uncertainty "
            "(the test pose's lines above say how much); `bayescal plan` (its predicted ±3σ) says whether a plan of this cell would "
            "measure them, and which to re-measure."
        )
    if limited:
        steps.append(f"{', '.join(limited)} keep{'s' if len(limited) == 1 else ''} the config's value, {'its' if len(limited) == 1 else 'their'} "
                     f"prior in the error bounds: no campaign of this cell can identify {'it' if len(limited) == 1 else 'them'} (see the reason above).")
    if error_q9973_mm is not None:
        steps.append(
            f"The result is usable for compensation (`bayescal compensate`) if an error of {error_length(error_q9973_mm)} "
            "(99.73 % at the test pose, everything counted) is within your tolerance."
        )
    return "Next: " + " ".join(steps) if steps else "Next: the fit is consistent with the repeats; the result can be used."


def critique_next_steps(causes: list[str], lack_of_fit: bool, classical_error_mm: float, negligible: Sequence[str] = ()) -> str:
    """One or two sentences on what to do after a critique of the elastostatic model.

    Parameters
    ----------
    causes : list of str
        The named causes in order of gain (empty when the verdict is adequate); may end with ``"unexplained"``.
    lack_of_fit : bool
        Whether the final model misses the configuration means by more than the repeats allow.
    classical_error_mm : float
        How far the classical model's test-pose prediction lies from the extended one's (mm).
    negligible : sequence of str
        The named causes detectable but too small to matter: each moves the test pose's prediction, and
        explains a misfit across the campaign, by less than the calibration's own uncertainty at the test pose.
    """
    gap = f"{classical_error_mm * 1000:.0f} μm"
    if not causes and not lack_of_fit:
        return "Next: the classical model is enough for this campaign; calibrate with it (`bayescal calibrate`) and compensate with its result."
    named = [cause for cause in causes if cause != "unexplained"]
    if not named:
        return (
            "Next: the repeats show a misfit that no cause of the catalogue matches; re-measure a few configurations, "
            "check the markers and the tracker's registration, and do not compensate with this campaign until the misfit is gone."
        )
    if all(cause in negligible for cause in named) and not lack_of_fit:
        return (
            f"Next: {', '.join(named)} {'is' if len(named) == 1 else 'are'} detectable on held-out configurations but too small to matter: "
            f"the test pose's prediction moves by {gap}, within the calibration's own uncertainty there; calibrate with the "
            "classical model (`bayescal calibrate`) and do not re-measure the cell for it."
        )
    return (
        f"Next: the classical model misses {', '.join(named)} (largest gain first; `docs/critique.md` says what each means and how to "
        f"remove it at the measurement). At the test pose the classical prediction is {gap} from the extended one's: "
        "compensate with the classical calibration only if that is within your tolerance."
    )
