"""The model ladder on measured points (``bayescal critique POSITIONS.csv --json``) as a section of the review.

Renders :class:`~bayescal.kinematics.ladder.LadderFindings` (read back by :meth:`~bayescal.kinematics.ladder.LadderFindings.load`)
beside the published values of :mod:`bayescal.kinematics.ladder`; it computes nothing.
"""

from __future__ import annotations


from bayescal.kinematics.ladder import PUBLISHED, PUBLISHED_SOURCE, PUBLISHED_WITHOUT, LadderFindings
from bayescal.numbers import fixed, table_texts
from bayescal.reports.page import Page

__all__ = ["ladder_section"]

_RUNG_COLUMNS = {
    "mean_mm": "held-out mean [mm]", "sd_mm": "sd [mm]", "max_mm": "max [mm]", "in_sample_mean_mm": "in-sample mean [mm]",
    "elpd": "ELPD [nats]", "elpd_se": "SE [nats]", "coverage_95": "95 % ellipsoid covers",
}


def ladder_section(page: Page, ladder: LadderFindings, source: str) -> None:
    """Each rung's held-out errors beside the published ones, each step's gain, and the leave-one-group-out table."""
    page.heading("ladder", "Model ladder on measured points")
    if source:
        page.paragraph(f"From {source}: {ladder.folds}-fold cross-validation by configuration.")
    page.paragraph(ladder.verdict, css="verdict")
    rungs = ladder.rungs
    frame = rungs[[key for key in _RUNG_COLUMNS if key in rungs]].rename(columns=_RUNG_COLUMNS)
    frame["published mean / sd / max [mm]"] = [" / ".join(f"{v:.2f}" for v in PUBLISHED[name]) if name in PUBLISHED else "–" for name in frame.index]
    formats = {column: fixed(0 if "nats" in column else 3 if "covers" in column else 2) for column in frame.columns if "published" not in column}
    page.table("rungs", frame, shown=table_texts(frame, {}, formats))
    steps = ladder.steps
    if steps:
        page.items(
            [
                f"{s['from']} → {s['to']} (+{', '.join(s['adds'])}): ΔELPD {s['elpd_gain']:+.0f} ± {s['elpd_gain_se']:.0f} nats, mean error "
                f"{s['error_change_mm']:+.2f} mm: {'called for by the data' if s['named'] else 'not called for'}"
                for s in steps
            ]
        )
        page.record("steps", list(steps))
    if len(ladder.without):
        table = ladder.without
        shown = table[[c for c in ("mean_mm", "elpd_loss", "elpd_loss_se") if c in table]].rename(
            columns={"mean_mm": "held-out mean [mm]", "elpd_loss": "ELPD lost [nats]", "elpd_loss_se": "SE [nats]"}
        )
        shown["published mean [mm]"] = [f"{PUBLISHED_WITHOUT[name]:.2f}" if name in PUBLISHED_WITHOUT else "–" for name in shown.index]
        shown.index.name = "full model without"
        page.table("without", shown, shown=table_texts(shown, {}, {c: fixed(0 if "nats" in c else 2) for c in shown.columns if "published" not in c}))
    page.paragraph(f"Published values: {PUBLISHED_SOURCE}.")
    page.close()
