"""The model ladder on measured points: each rung fitted, scored on held-out configurations, the gain of each step.

:class:`ModelLadder` fits every rung of :data:`~bayescal.kinematics.model.RUNGS`
and :data:`~bayescal.kinematics.model.EXTENSIONS`, and each leave-one-group-out
model of ``full`` (the published model, whose table it is compared with), with
k-fold cross-validation by configuration (no fold's configurations are seen by
its fit), and scores each on the held-out markers: the distance to the predicted
position (mm), the coverage of the 95 % predictive ellipsoid, and the log
predictive density (the k-fold ELPD, nats, with its standard error over
configurations).  A step up the ladder is
named as what the data call for when its ELPD gain exceeds :data:`DECISIVE_SE`
standard errors of the paired difference: the extension explains what the rung
below gets wrong on configurations it has not seen.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from os import PathLike

import numpy as np
import pandas as pd

from bayescal.kinematics.cell import PointsCell
from bayescal.kinematics.fit import KinematicCalibration
from bayescal.kinematics.model import EXTENSIONS, GROUPS, RUNGS, PointModel
from bayescal.kinematics.positions import Positions
from bayescal.jsonfiles import JsonSchema, read_json_object
from bayescal.kinematics.results import KinematicResults
from bayescal.summary import Column, Paragraph, Summary, Table

__all__ = ["LadderFindings", "ModelLadder", "DECISIVE_SE", "PUBLISHED", "LADDER_KIND", "LADDER_JSON"]

LADDER_KIND = "bayescal model ladder"

LADDER_JSON = JsonSchema({"verdict": str, "rungs": list, "steps": list, "without": list, "folds": int},
                         "bayescal critique POSITIONS.csv --config POINTS_CELL.toml --json")
"""What a reader of :meth:`LadderFindings.to_json`'s file relies on (its ``kind`` is :data:`LADDER_KIND`)."""
"""The ``kind`` of the ladder's JSON: how ``bayescal report --critique`` tells it from a campaign's critique."""

PUBLISHED_SOURCE = "Tenhumberg and Bäuml, Humanoids 2021 (Agile Justin, 500 configurations)"
"""Where :data:`PUBLISHED` and :data:`PUBLISHED_WITHOUT` come from."""

DECISIVE_SE = 2.0
"""A step's held-out ELPD gain must exceed this many standard errors of the paired difference to be named."""

COVERAGE_LEVEL = 0.95
"""The predictive ellipsoid whose held-out coverage is reported."""

PUBLISHED = {
    "frames": (21.33, 9.71, 63.41), "offsets": (18.18, 7.8, 45.9), "geometry": (10.5, 5.74, 36.37),
    "joint-elastic": (5.64, 2.57, 12.83), "full": (3.12, 1.71, 8.23),
}
"""Tenhumberg and Bäuml (Humanoids 2021), residual hand error over Justin's 500 configurations (mm): mean, sd, max per model."""

PUBLISHED_WITHOUT = {"k_theta": 9.09, "alpha": 6.48, "theta": 6.35, "k_alpha": 4.85, "r": 4.33, "d": 3.46}
"""Their leave-one-group-out table: mean error (mm) of the full model without each group."""


@dataclass(frozen=True)
class Scores:
    """Held-out scores of one model: per configuration, summed over its markers."""

    errors: np.ndarray
    log_density: np.ndarray
    covered: np.ndarray
    in_sample: np.ndarray
    model_sd: float

    def row(self) -> dict:
        n = len(self.log_density)
        return {"mean_mm": float(self.errors.mean() * 1e3), "sd_mm": float(self.errors.std() * 1e3), "max_mm": float(self.errors.max() * 1e3),
                "in_sample_mean_mm": float(self.in_sample.mean() * 1e3), "elpd": float(self.log_density.sum()),
                "elpd_se": float(np.sqrt(n) * self.log_density.std()), "coverage_95": float(self.covered.mean()),
                "model_error_sd_mm": self.model_sd * 1e3}


@dataclass(frozen=True)
class LadderFindings:
    """What the ladder found: each rung's held-out table, each step's gain, the leave-one-group-out table.

    Attributes
    ----------
    rungs : pandas.DataFrame
        One row per rung: held-out mean, sd, max error (mm), in-sample mean, ELPD ± SE, 95 % coverage, the
        model error's sd, and the published row beside it.
    steps : list of dict
        Each step up the ladder: the groups it adds, the ELPD gain ± SE, the error's change (mm), whether named.
    without : pandas.DataFrame
        One row per group left out of the full model (the published mean beside it).
    folds : int
    """

    rungs: pd.DataFrame
    steps: list[dict]
    without: pd.DataFrame
    folds: int
    verdict: str = field(default="")

    def summary(self) -> pd.DataFrame:
        return self.rungs

    def diagnostics(self) -> dict:
        return {"folds": self.folds, "steps": self.steps}

    def to_json(self) -> dict:
        return {"kind": LADDER_KIND, "folds": self.folds, "verdict": self.verdict,
                "rungs": self.rungs.reset_index().to_dict(orient="records"), "steps": self.steps,
                "without": self.without.reset_index().to_dict(orient="records"),
                "published": {"source": PUBLISHED_SOURCE, "rungs_mean_sd_max_mm": PUBLISHED, "without_mean_mm": PUBLISHED_WITHOUT}}

    @classmethod
    def from_json(cls, data: dict) -> LadderFindings:
        """The findings :meth:`to_json` gave (its ``published`` block is this module's :data:`PUBLISHED`, not read back)."""
        rungs = pd.DataFrame.from_records(data["rungs"]).set_index("model")
        without = pd.DataFrame.from_records(data["without"])
        return cls(rungs, list(data["steps"]), without.set_index("without") if len(without) else without, int(data["folds"]), str(data["verdict"]))

    @classmethod
    def load(cls, path: str | PathLike[str], option: str = "the model ladder file") -> LadderFindings:
        """The findings in the JSON file at ``path`` (``bayescal critique POSITIONS.csv --json``), checked against
        :data:`LADDER_JSON`; ``option`` names the file in errors and in the record of files read."""
        data = read_json_object(path, option)
        LADDER_JSON.check_kind(data, str(path), option)
        LADDER_JSON.check_keys(data, str(path))
        return cls.from_json(data)

    def document(self) -> Summary:
        """The findings as one document (:mod:`bayescal.summary`): each rung's held-out errors (mm) and ELPD (nats) beside
        the published ones, each step up the ladder, the full model with a group left out, and the verdict."""
        columns = (Column("model", width=16, align="<"), Column("mean", "mm", width=7), Column("sd", "mm", width=7),
                   Column("max", "mm", width=8), Column("in-sample", "mm", width=11), Column("ELPD", "nats", width=11),
                   Column("± SE", "nats", width=8), Column("cover95", width=9), Column("paper mean/sd/max", "mm", width=22))
        rows, values = [], []
        for name, r in self.rungs.iterrows():
            paper = PUBLISHED.get(name)
            rows.append((str(name), f"{r.mean_mm:.2f}", f"{r.sd_mm:.2f}", f"{r.max_mm:.2f}", f"{r.in_sample_mean_mm:.2f}", f"{r.elpd:.0f}",
                         f"{r.elpd_se:.0f}", f"{r.coverage_95:.3f}", "" if paper is None else "/".join(f"{v:.2f}" for v in paper)))
            values.append({"model": name, "mean": r.mean_mm, "sd": r.sd_mm, "max": r.max_mm, "in-sample": r.in_sample_mean_mm, "ELPD": r.elpd,
                           "± SE": r.elpd_se, "cover95": r.coverage_95, "paper mean/sd/max": paper})
        blocks = [Table("rungs", columns, tuple(rows), tuple(values)),
                  Paragraph("steps up the ladder (held-out ELPD gain ± SE of the paired difference):")]
        blocks += [Paragraph(f"{s['from']} → {s['to']} (+{', '.join(s['adds'])}): ΔELPD {s['elpd_gain']:+.0f} ± {s['elpd_gain_se']:.0f}, "
                             f"mean error {s['error_change_mm']:+.2f} mm: {'called for by the data' if s['named'] else 'not called for'}", indent="  ")
                   for s in self.steps]
        if len(self.without):
            blocks.append(Paragraph("leave one group out of the full model (held-out mean error, mm; published beside):"))
            for name, r in self.without.iterrows():
                paper = PUBLISHED_WITHOUT.get(name)
                blocks.append(Paragraph(f"without {name:<9}{r.mean_mm:>7.2f}   ΔELPD {r.elpd_loss:+.0f} ± {r.elpd_loss_se:.0f}"
                                        + ("" if paper is None else f"   (paper {paper:.2f})"), indent="  "))
        blocks.append(Paragraph(self.verdict))
        return Summary(f"model ladder, {self.folds}-fold cross-validation by configuration (held-out errors, mm; published beside):", tuple(blocks))


class ModelLadder:
    """Fit and score the ladder's rungs and the leave-one-group-out models on a cell's measured points.

    Parameters
    ----------
    cell
        The cell of measured points.
    folds
        Number of folds of the cross-validation by configuration (at least 2).
    rungs
        The rungs to fit, in order (default all of :data:`RUNGS` and :data:`EXTENSIONS`).
    leave_out
        Whether to fit the full model (the last rung when ``full`` is not fitted) without each of its groups.
    seed
        Seed of the folds' random assignment.
    """

    def __init__(self, cell: PointsCell, *, folds: int = 10, rungs: tuple[str, ...] = RUNGS + EXTENSIONS, leave_out: bool = True,
                 seed: int = 0) -> None:
        if folds < 2:
            raise ValueError(f"folds must be at least 2, got {folds}")
        self.cell, self.folds, self.rungs, self.leave_out, self.seed = cell, folds, tuple(rungs), leave_out, seed

    def run(self, positions: Positions) -> LadderFindings:
        """The findings on ``positions`` (every configuration with every marker)."""
        n = len(positions)
        if n < self.folds:
            raise ValueError(f"{n} configurations cannot be split into {self.folds} folds")
        assignment = np.random.default_rng(self.seed).permutation(n) % self.folds
        scores, fits = {}, {}
        rungs = self._rungs()
        for rung in rungs:
            fits[rung] = KinematicCalibration(self.cell, rung).fit(positions)
            scores[rung] = self._score(rung, (), positions, assignment, fits[rung])
        rows = pd.DataFrame({rung: s.row() for rung, s in scores.items()}).T
        rows.index.name = "model"
        steps = []
        for lower, upper in zip(rungs, rungs[1:]):
            gain = scores[upper].log_density - scores[lower].log_density
            se = float(np.sqrt(n) * gain.std())
            steps.append({"from": lower, "to": upper, "adds": sorted(set(GROUPS[upper]) - set(GROUPS[lower])),
                          "elpd_gain": float(gain.sum()), "elpd_gain_se": se,
                          "error_change_mm": float((scores[upper].errors.mean() - scores[lower].errors.mean()) * 1e3),
                          "named": bool(gain.sum() > DECISIVE_SE * se)})
        without = {}
        top = "full" if "full" in rungs else rungs[-1]
        if self.leave_out:
            for group in GROUPS[top]:
                if group == "frames":
                    continue
                s = self._score(top, (group,), positions, assignment, fits[top])
                loss = scores[top].log_density - s.log_density
                without[group] = s.row() | {"elpd_loss": float(loss.sum()), "elpd_loss_se": float(np.sqrt(n) * loss.std())}
        table = pd.DataFrame(without).T
        table.index.name = "without"
        return LadderFindings(rungs=rows, steps=steps, without=table, folds=self.folds, verdict=_verdict(steps, rows))

    def _rungs(self) -> tuple[str, ...]:
        """The rungs to fit: an extension that adds no parameter on this cell (no coupling law to make mutual) is left out."""
        sizes = {rung: PointModel(self.cell, rung).size for rung in self.rungs}
        return tuple(r for i, r in enumerate(self.rungs) if i == 0 or r not in EXTENSIONS or sizes[r] > sizes[self.rungs[i - 1]])

    def _score(self, rung: str, without: tuple[str, ...], positions: Positions, assignment: np.ndarray,
               whole: KinematicResults) -> Scores:
        """Held-out scores of one model, each fold fitted from the whole data's mode of ``whole``."""
        n, markers = positions.xyz.shape[:2]
        errors, log_density, covered = np.empty((n, markers)), np.empty(n), np.empty((n, markers))
        calibration = KinematicCalibration(self.cell, rung, without=without)
        whole_fit = whole if not without else calibration.fit(positions, start=whole)
        # Imported here: the review page imports this module for LADDER_KIND alone, and scipy.stats was 0.46 s of its 4.6 s.
        from scipy import stats

        threshold = stats.chi2.ppf(COVERAGE_LEVEL, 3)
        for fold in range(self.folds):
            test = np.flatnonzero(assignment == fold)
            fit = calibration.fit(positions.take(np.flatnonzero(assignment != fold)), start=whole_fit)
            mean, covariance = fit.predict(positions.joints[test])
            residual = positions.xyz[test] - mean
            errors[test] = np.linalg.norm(residual, axis=-1)
            solved = np.linalg.solve(covariance, residual[..., None])[..., 0]
            distance = np.sum(residual * solved, axis=-1)
            covered[test] = distance <= threshold
            _, logdet = np.linalg.slogdet(covariance)
            log_density[test] = np.sum(-0.5 * (distance + logdet + 3 * np.log(2 * np.pi)), axis=1)
        return Scores(errors=errors, log_density=log_density, covered=covered, in_sample=whole_fit.errors(), model_sd=whole_fit.model_sd)


def _verdict(steps: list[dict], rungs: pd.DataFrame) -> str:
    named = [s for s in steps if s["named"]]
    if not named:
        return "verdict: no step up the ladder improves the held-out predictions decisively"
    last = named[-1]
    remaining = [s["to"] for s in steps if not s["named"]]
    text = (f"verdict: the data call for {', '.join(s['to'] for s in named)}; the last such step, {last['to']} "
            f"(+{', '.join(last['adds'])}), gains {last['elpd_gain']:.0f} ± {last['elpd_gain_se']:.0f} nats held out")
    if remaining:
        text += f"; not called for: {', '.join(remaining)}"
    best = rungs["elpd"].idxmax()
    return text + f". Best held-out model: {best}, {rungs.loc[best, 'mean_mm']:.2f} mm mean error"
