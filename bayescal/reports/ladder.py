"""The model ladder on measured points (``bayescal critique POSITIONS.csv --json``) as a section of the review.

Renders :meth:`~bayescal.kinematics.ladder.LadderFindings.to_json`; it computes nothing.
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from bayescal.numbers import fixed, table_texts
from bayescal.reports.page import Page

__all__ = ["ladder_section"]

_RUNG_COLUMNS = {
    "mean_mm": "held-out mean [mm]", "sd_mm": "sd [mm]", "max_mm": "max [mm]", "in_sample_mean_mm": "in-sample mean [mm]",
    "elpd": "ELPD [nats]", "elpd_se": "SE [nats]", "coverage_95": "95 % ellipsoid covers",
}


def ladder_section(page: Page, ladder: Mapping, source: str) -> None:
    """Each rung's held-out errors beside the published ones, each step's gain, and the leave-one-group-out table."""
    page.heading("ladder", "Model ladder on measured points")
    if source:
        page.paragraph(f"From {source}: {ladder.get('folds', '?')}-fold cross-validation by configuration.")
    page.paragraph(str(ladder.get("verdict", "")), css="verdict")
    published = ladder.get("published", {})
    rungs = pd.DataFrame.from_records(ladder["rungs"]).set_index("model")
    frame = rungs[[key for key in _RUNG_COLUMNS if key in rungs]].rename(columns=_RUNG_COLUMNS)
    paper = published.get("rungs_mean_sd_max_mm", {})
    if paper:
        frame["published mean / sd / max [mm]"] = [
            " / ".join(f"{v:.2f}" for v in paper[name]) if name in paper else "–" for name in frame.index
        ]
    formats = {column: fixed(0 if "nats" in column else 3 if "covers" in column else 2) for column in frame.columns if "published" not in column}
    page.table("rungs", frame, shown=table_texts(frame, {}, formats))
    steps = ladder.get("steps", [])
    if steps:
        page.items(
            [
                f"{s['from']} → {s['to']} (+{', '.join(s['adds'])}): ΔELPD {s['elpd_gain']:+.0f} ± {s['elpd_gain_se']:.0f} nats, mean error "
                f"{s['error_change_mm']:+.2f} mm: {'called for by the data' if s['named'] else 'not called for'}"
                for s in steps
            ]
        )
        page.record("steps", list(steps))
    without = ladder.get("without", [])
    if without:
        table = pd.DataFrame.from_records(without).set_index("without")
        shown = table[[c for c in ("mean_mm", "elpd_loss", "elpd_loss_se") if c in table]].rename(
            columns={"mean_mm": "held-out mean [mm]", "elpd_loss": "ELPD lost [nats]", "elpd_loss_se": "SE [nats]"}
        )
        paper_without = published.get("without_mean_mm", {})
        if paper_without:
            shown["published mean [mm]"] = [f"{paper_without[name]:.2f}" if name in paper_without else "–" for name in shown.index]
        shown.index.name = "full model without"
        page.table("without", shown, shown=table_texts(shown, {}, {c: fixed(0 if "nats" in c else 2) for c in shown.columns if "published" not in c}))
    if published.get("source"):
        page.paragraph(f"Published values: {published['source']}.")
    page.close()
