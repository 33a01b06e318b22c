"""The test pose's error budget as text: what ``calibrate`` prints and the review's summary repeats.

Renders the ``test_pose`` block of :meth:`~bayescal.compensation.testpose.TestPosePrediction.to_json`;
it computes nothing.
"""

from __future__ import annotations

import textwrap

from bayescal.compensation.results import DECIMALS
from bayescal.numbers import deflection_mm, error_length, fixed

__all__ = ["test_pose_lines", "unidentified_sentence"]


def unidentified_sentence(error: dict) -> str:
    """What the parameters the campaign cannot identify add at 99.73 %, with their prior and how to identify them."""
    names = error["unidentified"]
    from_prior = [name for name in names if name in error["priors"]]
    sampled = [name for name in names if name not in error["priors"]]
    who = []
    if from_prior:
        priors = "; ".join(
            f"log-normal about the config's {prior['median']:.4g} {prior['unit']}, log-sd {prior['log_sd']:g} ({prior['source']})"
            for prior in (error["priors"][name] for name in from_prior)
        )
        who.append(f"{', '.join(from_prior)}, which this campaign cannot identify (prior: {priors})")
    if sampled:
        who.append(f"{', '.join(sampled)}, which it barely determines (their posterior is close to their prior)")
    return (
        f"{' and '.join(who)} add {error_length(error['added_by_unidentified_q99.73'])} at 99.73 % "
        f"({error['unidentified_share_of_mean_square']:.0%} of the mean-square error); a campaign that loads them identifies "
        "them (for k1 of an upright arm, a sideways load): `bayescal plan` designs one."
    )


def test_pose_lines(block: dict) -> list[str]:
    """The lines of an available test-pose block: deflection, corrected joints, the error left and its parts."""
    norm = block["deflection_norm_mm"]
    error = block["residual_error_mm"]
    identified = error["identified_only"]
    targets = ", ".join(
        f"{name} {fixed(DECIMALS)(value)} {key.split('_', 1)[1]}"
        for name, entry in block["joints"].items()
        for key, value in entry.items()
        if key.startswith("compensated")
    )
    lines = [
        f"test pose: the correction removes a deflection of {deflection_mm(block['corrected_deflection_mm']['norm'])} "
        f"(over the draws {deflection_mm(norm['mean'], 3 * norm['sd'])}, ±3σ) with the compensated targets",
        f"  {targets}",
        f"  error left after compensation, everything counted: rms {error_length(error['rms'])}, 95% {error_length(error['q95'])}, "
        f"99.73% {error_length(error['q99.73'])}",
    ]
    if error["unidentified"]:
        lines.append(
            f"  from the identified parameters alone: rms {error_length(identified['rms'])}, 95% {error_length(identified['q95'])}, "
            f"99.73% {error_length(identified['q99.73'])}"
        )
        lines += textwrap.wrap(unidentified_sentence(error), width=100, initial_indent="  ", subsequent_indent="    ")
    return lines
