"""What a compensation found: the compensated program, its per-pose error and the summary."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.compensation.budget import ErrorBudget
from bayescal.compensation.program import Program, compensated_columns
from bayescal.jsonsafe import json_safe
from bayescal.robot.kinematics import Robot
from bayescal.summary import Paragraph, Summary
from bayescal.units import MM

__all__ = ["CompensationResults", "FLAG_OK", "DECIMALS", "WORST", "SUMMARY_COLUMNS"]

FLAG_OK = "ok"
"""The ``flag`` of a pose with nothing to report."""

WORST = 10
"""Poses listed in :meth:`CompensationResults.to_json`'s ``worst_poses``."""

DECIMALS = 4
"""Decimals of the compensated targets (deg or mm) and the lengths (mm) in the written program: what KUKA
KRL and ABB RAPID take for axis values (a ten-thousandth of a degree moves a tool 3 m out by 5 μm)."""

SUMMARY_COLUMNS = ("deflection_mm", "error_rms_mm", "error_q9973_mm")
"""The compensated file's lengths (of :data:`~bayescal.compensation.program.LENGTH_COLUMNS`) whose median and
largest value over the program :meth:`CompensationResults.summary` and the review's section give."""


@dataclass
class CompensationResults:
    """The compensated program (SI inside).

    Attributes
    ----------
    program : Program
    robot : Robot
    commands : numpy.ndarray
        ``(P, n)`` compensated joint targets, rad (NaN where no equilibrium was found).
    deflection_xyz : numpy.ndarray
        ``(P, 3)`` the tool point's deflection under the wrench at the programmed joints with the
        applied (median) compliances, linear map of eq 31 (m, base axes): the error without compensation,
        which the correction removes.
    budget : ErrorBudget
        The error left after compensation at each pose over the draws, and the unidentified parameters' part.
    failed : numpy.ndarray
        ``(P,)`` True where the equilibrium under the wrench was not found.
    tolerance : float or None
        The flagging tolerance on the 99.73 % error (m).
    n_draws : int
        Posterior draws spread through every pose.
    """

    program: Program
    robot: Robot
    commands: np.ndarray
    deflection_xyz: np.ndarray
    budget: ErrorBudget
    failed: np.ndarray
    tolerance: float | None = None
    n_draws: int = 0
    _flags: list[str] | None = field(default=None, repr=False)

    @property
    def deflection(self) -> np.ndarray:
        """``(P,)`` length of :attr:`deflection_xyz` (m)."""
        return np.linalg.norm(self.deflection_xyz, axis=1)

    @property
    def errors(self) -> dict[str, np.ndarray]:
        """``rms``, ``q95``, ``q9973``: ``(P,)`` error left after compensation over every parameter's draws (m)."""
        return self.budget.total

    @property
    def unidentified(self) -> tuple[str, ...]:
        """The parameters the calibration did not identify, drawn from their prior."""
        return self.budget.unidentified

    @property
    def unidentified_share(self) -> np.ndarray:
        """``(P,)`` fraction of the mean-square error due to :attr:`unidentified`."""
        return self.budget.unidentified_share

    @property
    def flags(self) -> list[str]:
        """Per pose: ``"ok"`` or the reasons, ``;``-separated (no equilibrium, a target outside its joint's
        limits, never clipped, or a 99.73 % error beyond the tolerance with what dominates it)."""
        if self._flags is None:
            self._flags = [self._flag(p) for p in range(len(self.program))]
        return self._flags

    def _flag(self, p: int) -> str:
        if self.failed[p]:
            return "no static equilibrium under this wrench"
        reasons = []
        robot = self.robot
        for j, (value, low, high) in enumerate(zip(self.commands[p], robot.lower, robot.upper)):
            if not low <= value <= high:
                scale, unit = robot.position_scale[j], robot.position_units[j]
                reasons.append(f"q{j + 1}_cmd {value / scale:.3f} {unit} outside the limits {low / scale:.1f} to {high / scale:.1f} {unit}")
        bound = self.errors["q9973"][p]
        if self.tolerance is not None and bound > self.tolerance:
            share = self.unidentified_share[p]
            cause = (
                f"{share:.0%} of it from {', '.join(self.unidentified)}, not identified by the calibration"
                if self.unidentified and share >= 0.5
                else "mostly from the identified parameters' uncertainty"
            )
            reasons.append(f"99.73% error {bound / MM:.4f} mm above the tolerance {self.tolerance / MM:g} mm ({cause})")
        return "; ".join(reasons) or FLAG_OK

    def table(self) -> pd.DataFrame:
        """The compensated program: the input's columns, ``q<j>_cmd_deg`` (``q<j>_cmd_mm`` for a prismatic joint),
        ``deflection_mm``, the error columns, ``flag``."""
        out = self.program.table.copy()
        commands = [self.commands[:, j] / scale for j, scale in enumerate(self.robot.position_scale)]
        lengths = [self.deflection, self.errors["rms"], self.errors["q95"], self.errors["q9973"], self.budget.identified["q9973"]]
        values = commands + [length / MM for length in lengths] + [self.unidentified_share, self.flags]
        for name, value in zip(compensated_columns(self.robot), values, strict=True):
            out[name] = value
        return out

    def save(self, path: str | PathLike[str], decimals: int = DECIMALS) -> None:
        """Write :meth:`table` as CSV: the input's columns as written, the new numbers with ``decimals``
        fixed decimals (a controller reads ``-0.0000``, not ``-7.9e-19``), the share with 3."""
        from bayescal.numbers import fixed

        table = self.table()
        added = [name for name in table.columns if name not in self.program.table.columns and name != "flag"]
        for name in added:
            write = fixed(3 if name == "unidentified_share" else decimals)
            # A pose without equilibrium keeps its NaN targets written as such, not as a number.
            table[name] = [write(value) if math.isfinite(value) else "nan" for value in table[name]]
        table.to_csv(path, index=False)

    def summary(self) -> pd.DataFrame:
        """Program-level statistics over the poses, columns ``median`` and ``max``: the deflection without
        compensation (``deflection_mm``, poses with an equilibrium), the errors left (``error_rms_mm``,
        ``error_q9973_mm``) and the unidentified parameters' share of the mean-square error (a fraction)."""
        ok = ~self.failed
        lengths = dict(zip(SUMMARY_COLUMNS, (self.deflection[ok], self.errors["rms"], self.errors["q9973"]), strict=True))
        columns = {name: length / MM for name, length in lengths.items()}
        columns["unidentified_share_of_mean_square_error"] = self.unidentified_share
        rows = {name: [np.median(v) if v.size else math.nan, np.max(v) if v.size else math.nan] for name, v in columns.items()}
        return pd.DataFrame.from_dict(rows, orient="index", columns=["median", "max"])

    def diagnostics(self) -> dict:
        """How large the corrections are (deg; mm for a prismatic joint), draws used, and poses without a static equilibrium."""
        ok = ~self.failed
        programmed = self.program.q[ok]
        scale = self.robot.position_scale
        correction = np.abs(self.commands[ok] - programmed) / scale if ok.any() else np.empty((0, programmed.shape[1]))
        largest = correction.max(axis=0, initial=0.0)
        return {
            "draws": self.n_draws,
            "largest_joint_correction_deg": {f"q{j + 1}": float(c) for j, c in enumerate(largest) if not self.robot.prismatic[j]},
            "largest_joint_correction_mm": {f"q{j + 1}": float(c) for j, c in enumerate(largest) if self.robot.prismatic[j]},
            "equilibrium_failures": int(self.failed.sum()),
        }

    def document(self) -> Summary:
        """The compensation as one document (:mod:`bayescal.summary`), the text ``bayescal compensate`` prints: the poses,
        the deflection removed, the worst 99.73 % bound and what dominates it, the flags."""
        from bayescal.numbers import error_length

        summary = self._summary_json()
        lines = []
        if len(self.program) and np.isfinite(self.errors["q9973"]).any():
            worst = int(np.nanargmax(self.errors["q9973"]))
            share = self.unidentified_share[worst]
            cause = (
                f"{share:.0%} of its mean square from {', '.join(self.unidentified)}, which the calibration did not identify "
                f"(from the identified parameters alone: {error_length(self.budget.identified['q9973'][worst] / MM)})"
                if self.unidentified and share >= 0.5
                else "mostly from the identified parameters' uncertainty"
            )
            lines += [
                f"deflection removed: median {error_length(summary['deflection_mm']['median'])}, largest {error_length(summary['deflection_mm']['max'])}",
                f"error left (99.73 %, everything counted): median {error_length(summary['error_q9973_mm']['median'])}, "
                f"worst {error_length(self.errors['q9973'][worst] / MM)} at line {int(self.program.lines[worst])}: {cause}",
            ]
        lines.append(
            f"flagged: {summary['flagged']} ({summary['outside_joint_limits']} outside the joint limits, {summary['no_equilibrium']} without "
            "equilibrium" + ("" if self.tolerance is None else f", tolerance {self.tolerance / MM:g} mm") + ")"
        )
        title = f"{self.program.source or 'program'}: {summary['poses']} poses compensated over {self.n_draws} draws"
        return Summary(title, tuple(Paragraph(line) for line in lines))

    def to_json(self) -> dict:
        """Summary, diagnostics and the :data:`WORST` poses by their 99.73 % error."""
        order = np.argsort(-self.errors["q9973"])[:WORST]
        lines = self.program.lines
        worst = [
            {
                "line": int(lines[p]),
                "error_q9973_mm": float(self.errors["q9973"][p] / MM),
                "error_rms_mm": float(self.errors["rms"][p] / MM),
                "deflection_mm": float(self.deflection[p] / MM) if math.isfinite(self.deflection[p]) else None,
                "flag": self.flags[p],
            }
            for p in order
        ]
        return {"summary": self._summary_json(), "diagnostics": self.diagnostics(), "worst_poses": worst}

    def _summary_json(self) -> dict:
        """:meth:`summary` with the program's counts: poses, draws, parameters not identified, tolerance, flags."""
        flags = self.flags
        stats = {name: {"median": json_safe(float(row["median"])), "max": json_safe(float(row["max"]))} for name, row in self.summary().iterrows()}
        return {
            "poses": len(self.program),
            "draws": self.n_draws,
            "deflection_mm": stats["deflection_mm"],
            "error_rms_mm": stats["error_rms_mm"],
            "error_q9973_mm": stats["error_q9973_mm"],
            "unidentified": list(self.unidentified),
            "unidentified_share_of_mean_square_error": stats["unidentified_share_of_mean_square_error"],
            "tolerance_mm": None if self.tolerance is None else self.tolerance / MM,
            "flagged": int(sum(flag != FLAG_OK for flag in flags)),
            "outside_joint_limits": int(sum("outside the limits" in flag for flag in flags)),
            "no_equilibrium": int(self.failed.sum()),
        }
