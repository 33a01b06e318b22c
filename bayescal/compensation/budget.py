"""The error budget: the error left at poses after compensation, and what the campaign could not identify adds to it.

Every number this package gives for "the error left at this pose" comes from
here: the test pose of ``calibrate``, of the review and of ``plan --evaluate``'s
simulated campaigns, and every pose of ``compensate``.  The correction applies
one value of each parameter (its draws' median,
:attr:`~bayescal.compensation.calibration.Calibration.applied_own`); a draw
``k_s`` would have deflected the tool by ``A (k_s - k_applied)`` more
(:mod:`bayescal.compensation.spread`, eq 31): the error left.  Its quantiles over
the draws are the budget's total.  The draws of a parameter the campaign could
not identify are its prior's (the cell's ``[joints] k_log_sd``), so its share is
in the total; the budget also gives the error with those parameters held at
their applied value (``identified``), so that a reader sees which part the data
could have reduced and which part only another campaign can.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayescal.compensation.calibration import Calibration
from bayescal.compensation.spread import deflection_draws, error_quantiles
from bayescal.units import MM

__all__ = ["ErrorBudget", "error_budget", "CHUNK"]

CHUNK = 256
"""Poses whose draws are spread at once: ``S × CHUNK × n`` compliances in memory."""


@dataclass(frozen=True)
class ErrorBudget:
    """The error left after compensation at ``P`` poses, over the calibration's draws (SI).

    Attributes
    ----------
    total : dict
        ``rms``, ``q95``, ``q9973``: ``(P,)`` length of the error left (m), every parameter's spread counted.
    identified : dict
        The same with the parameters the campaign did not identify held at their applied value (m).
    applied : numpy.ndarray
        ``(P, n)`` the compliances the correction applies (rad/(N·m)); the compensated joint's is its
        equivalent compliance at the pose (eq 8).
    unidentified : tuple of str
        The parameters the campaign did not identify.
    priors : dict
        For each compliance drawn from its prior: its median and unit (edge units), log-sd and where that comes from.
    spread : numpy.ndarray or None
        ``(P, 3, S)`` each draw's deflection minus the applied one (m), when asked for.
    """

    total: dict[str, np.ndarray]
    identified: dict[str, np.ndarray]
    applied: np.ndarray
    unidentified: tuple[str, ...] = ()
    priors: dict = field(default_factory=dict)
    spread: np.ndarray | None = field(default=None, repr=False)

    @property
    def unidentified_share(self) -> np.ndarray:
        """``(P,)`` fraction of the mean-square error the unidentified parameters account for."""
        total = self.total["rms"] ** 2
        rest = self.identified["rms"] ** 2
        return np.clip(1.0 - np.divide(rest, total, out=np.ones_like(total), where=total > 0), 0.0, 1.0)

    def pose_json(self, p: int = 0) -> dict:
        """Pose ``p``'s budget in mm: the total, the identified parameters' part, and what the rest adds."""
        total = {name: float(self.total[key][p] / MM) for name, key in _KEYS}
        identified = {name: float(self.identified[key][p] / MM) for name, key in _KEYS}
        return {
            "rms": total["rms"],
            "q95": total["q95"],
            "q99.73": total["q99.73"],
            "includes": "every parameter's uncertainty: the posterior's, and the prior's of "
            + (", ".join(self.unidentified) + ", which the campaign does not identify" if self.unidentified else "none (every parameter identified)"),
            "identified_only": identified | {"includes": "the identified parameters only, the others held at their applied value"},
            "added_by_unidentified_q99.73": total["q99.73"] - identified["q99.73"],
            "unidentified_share_of_mean_square": float(self.unidentified_share[p]),
            "unidentified": list(self.unidentified),
            "priors": {name: dict(prior) for name, prior in self.priors.items()},
        }


_KEYS = (("rms", "rms"), ("q95", "q95"), ("q99.73", "q9973"))


def error_budget(calibration: Calibration, design: np.ndarray, q_compensated: np.ndarray, *, keep_spread: bool = False) -> ErrorBudget:
    """The error left at each pose after compensation with the applied (median) parameters, over the draws.

    Parameters
    ----------
    calibration
        The posterior draws (and the prior draws of what the campaign did not identify).
    design
        ``(P, 3, n)`` eq-31 matrices of the poses.
    q_compensated
        ``(P,)`` angle of the compensated joint at each pose, rad (ignored without a compensator).
    keep_spread
        Also return the ``(P, 3, S)`` deflections about the applied one (memory: ``24 P S`` bytes).
    """
    out: dict[str, list] = {"rms": [], "q95": [], "q9973": [], "applied": [], "identified_rms": [], "identified_q95": [], "identified_q9973": [], "spread": []}
    joint = calibration.compensated_joint
    full = _Spread(calibration.compliances(q_compensated), joint)
    held = _Spread(calibration.compliances(q_compensated, fixed=calibration.unidentified), joint) if calibration.unidentified else None
    for start in range(0, design.shape[0], CHUNK):
        part = slice(start, start + CHUNK)
        spread, applied = full(design[part], q_compensated[part])
        stats = error_quantiles(np.sqrt(np.einsum("pis,pis->ps", spread, spread)))
        if held is None:
            rest = stats
        else:
            rest_spread, _ = held(design[part], q_compensated[part])
            rest = error_quantiles(np.sqrt(np.einsum("pis,pis->ps", rest_spread, rest_spread)))
        for name, value in stats.items():
            out[name].append(value)
            out[f"identified_{name}"].append(rest[name])
        out["applied"].append(applied)
        if keep_spread:
            out["spread"].append(spread)
    joined = {name: np.concatenate(values) for name, values in out.items() if values}
    return ErrorBudget(
        total={name: joined[name] for name in ("rms", "q95", "q9973")},
        identified={name: joined[f"identified_{name}"] for name in ("rms", "q95", "q9973")},
        applied=joined["applied"],
        unidentified=calibration.unidentified,
        priors=dict(calibration.priors),
        spread=joined.get("spread"),
    )


class _Spread:
    """The draws' deflections about the applied one at a chunk of poses: ``(p, 3, S)`` and the ``(p, n)`` applied compliances."""

    def __init__(self, compliances, joint: int | None) -> None:
        self.own, self.equivalent = compliances
        self.median = np.median(self.own, axis=0)
        self.centred = self.own - self.median
        self.joint = joint

    def _varying(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        applied = np.repeat(self.median[None, :], len(angles), axis=0)
        if self.equivalent is None:
            return applied, None
        varying = self.equivalent(angles)
        applied[:, self.joint] = np.median(varying, axis=1)
        return applied, varying - applied[:, self.joint, None]

    def __call__(self, design: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        applied, varying = self._varying(angles)
        return deflection_draws(design, self.centred, varying, self.joint), applied
