"""The findings of the reports committed in ``reports/``: which data each reads and with which seed.

``bayescal report --paper-reports DIR`` (and ``make reports``) regenerates them:
for each name of :data:`PAPER_REPORTS` it computes :func:`paper_findings` from the
files of a :class:`PaperSources` and hands them to the report's renderer
(:func:`bayescal.reports.paper.render_paper_report`).  The detection report is
computed and rendered by :func:`bayescal.reports.detection.render_report` from the
same sources.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from bayescal.studies.elastostatic_findings import ElastostaticFindings
    from bayescal.studies.geometry_findings import GeometryFindings
    from bayescal.studies.twin_findings import TwinFindings

__all__ = ["PAPER_REPORTS", "PAPER_SEEDS", "PaperSources", "paper_findings"]

PAPER_REPORTS = ("geometry", "twin", "elastostatic", "detection")
"""The committed reports, in the order they are computed."""

PAPER_SEEDS = {"geometry": 1, "twin": 1, "elastostatic": 1, "detection": 0}
"""The seed of each committed report: the reports quote numbers of these runs."""


@dataclass(frozen=True)
class PaperSources:
    """The files the committed reports are computed from, by default those of a folder laid out as ``data/``.

    Attributes
    ----------
    points
        Klimchik et al.'s Table I (``table1_geometry.csv``).
    reference
        Their Tables II and IV (``paper_reference.csv``).
    config
        The KR-270 cell (``kr270.toml``).
    plan
        Their Table III plan (``table3_plan.csv``).
    compensator_plan
        The plan designed for the compensator (``compensator_plan.csv``), on which the detection
        report also studies the ``compensator`` effect.
    """

    points: Path
    reference: Path
    config: Path
    plan: Path
    compensator_plan: Path

    @classmethod
    def in_folder(cls, folder: str | Path) -> PaperSources:
        """The sources under their usual names in ``folder``."""
        folder = Path(folder)
        return cls(
            points=folder / "table1_geometry.csv",
            reference=folder / "paper_reference.csv",
            config=folder / "kr270.toml",
            plan=folder / "table3_plan.csv",
            compensator_plan=folder / "compensator_plan.csv",
        )

    def inputs(self) -> dict[str, Path]:
        """What each file is, for the output guard."""
        return {
            "Table I": self.points,
            "the published tables": self.reference,
            "the config": self.config,
            "the plan": self.plan,
            "the compensator plan": self.compensator_plan,
        }


def paper_findings(name: str, sources: PaperSources) -> GeometryFindings | TwinFindings | ElastostaticFindings:
    """The findings of the committed report ``name`` (``geometry``, ``twin`` or ``elastostatic``).

    Raises
    ------
    ValueError
        For ``detection`` (computed by its report module) or a name not in :data:`PAPER_REPORTS`.
    """
    # The studies are imported here: the command line lists the reports' names without loading them.
    seed = PAPER_SEEDS.get(name)
    if name == "geometry":
        from bayescal.studies.geometry_findings import geometry_findings

        return geometry_findings(sources.points, sources.reference, seed)
    if name == "twin":
        from bayescal.cell.config import load_cell
        from bayescal.cell.plan import read_plan
        from bayescal.studies.twin_findings import twin_findings

        cell = load_cell(sources.config)
        return twin_findings(cell, read_plan(sources.plan, cell.robot), seed=seed)
    if name == "elastostatic":
        from bayescal.studies.elastostatic_findings import elastostatic_findings

        return elastostatic_findings(sources.config, sources.plan, seed)
    raise ValueError(f"no findings function for the report {name!r}; expected one of geometry, twin, elastostatic")
