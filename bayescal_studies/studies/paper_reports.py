"""The findings of the reports committed in ``reports/``: which data each reads and with which seed.

``python -m bayescal_studies reports DIR`` (and ``make reports``) regenerates them:
for each name of :data:`PAPER_REPORTS` it computes :func:`paper_findings` from the
files of a :class:`PaperSources` and hands them to the report's renderer
(:func:`bayescal_studies.reports.paper.render_paper_report`, and
:func:`bayescal_studies.reports.detection.render_report` for the detection report).
"""

from __future__ import annotations

from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from bayescal.units import DEG

if TYPE_CHECKING:
    from bayescal_studies.studies.detection import DetectionFindings
    from bayescal_studies.studies.elastostatic_findings import ElastostaticFindings
    from bayescal_studies.studies.geometry_findings import GeometryFindings
    from bayescal_studies.studies.twin_findings import TwinFindings

__all__ = ["PAPER_REPORTS", "PAPER_SEEDS", "DETECTION_MAGNITUDES", "GEOMETRY_DETECTION_MAGNITUDES", "PaperSources", "paper_findings"]

PAPER_REPORTS = ("geometry", "twin", "elastostatic", "detection")
"""The committed reports, in the order they are computed."""

PAPER_SEEDS = {"geometry": 1, "twin": 1, "elastostatic": 1, "detection": 0}
"""The seed of each committed report: the reports quote numbers of these runs."""

DETECTION_MAGNITUDES: dict[str, tuple[float, ...]] = {
    "compensator": (5.0, 10.0, 20.0, 30.0, 50.0),
    "link_compliance": (0.25, 0.5, 1.0, 2.0),
    "tool_compliance": (0.3, 0.6, 1.0, 1.5),
    "backlash": (0.002, 0.005, 0.01, 0.015),
    "nonlinear_stiffness": (0.05, 0.1, 0.2, 0.3),
    "outliers": (0.0025, 0.005, 0.01, 0.02),
}
"""The detection report's magnitudes tried per effect of the twin (the effect's unit, docs/twin.md): from below the
detection limit to past it."""

GEOMETRY_DETECTION_MAGNITUDES: dict[str, tuple[float, ...]] = {
    "tilt": (2 * DEG, 3.5 * DEG, 5 * DEG),
    "pivot_motion": (5e-9, 1e-8, 1.5e-8),
    "cylinder_slip": (0.003, 0.006, 0.01),
    "joint_scale": (0.001, 0.002, 0.004),
    "closed_loop": (10.0, 25.0, 50.0),
    "lever_bending": (1e-8, 2e-8, 4e-8),
}
"""The detection report's magnitudes of the geometry critique's planted effects (units of :data:`~bayescal_studies.studies.geometry_critique.PLANTED`);
``lever_bending`` is outside its catalogue."""


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


def paper_findings(
    name: str, sources: PaperSources, *, executor: Executor | None = None
) -> GeometryFindings | TwinFindings | ElastostaticFindings | DetectionFindings:
    """The findings of the committed report ``name`` (one of :data:`PAPER_REPORTS`).

    ``executor`` runs the detection report's campaigns (:func:`~bayescal.design.parallel.seeded_map`;
    default a process pool per study); the other reports run here.

    Raises
    ------
    ValueError
        For a name not in :data:`PAPER_REPORTS`.
    """
    # The studies are imported here: the command line lists the reports' names without loading them.
    seed = PAPER_SEEDS.get(name)
    if name == "geometry":
        from bayescal_studies.studies.geometry_findings import geometry_findings

        return geometry_findings(sources.points, sources.reference, seed)
    if name == "twin":
        from bayescal.cell.config import load_cell
        from bayescal.cell.plan import read_plan
        from bayescal_studies.studies.twin_findings import twin_findings

        cell = load_cell(sources.config)
        return twin_findings(cell, read_plan(sources.plan, cell.robot), seed=seed)
    if name == "elastostatic":
        from bayescal_studies.studies.elastostatic_findings import elastostatic_findings

        return elastostatic_findings(sources.config, sources.plan, seed)
    if name == "detection":
        from bayescal_studies.studies.detection import detection_findings

        return detection_findings(
            str(sources.config),
            str(sources.plan),
            DETECTION_MAGNITUDES,
            other_plans={"compensator": str(sources.compensator_plan)},
            geometry_points=str(sources.points),
            geometry_magnitudes=GEOMETRY_DETECTION_MAGNITUDES,
            seed=seed,
            executor=executor,
        )
    raise ValueError(f"no findings function for the report {name!r}; expected one of {', '.join(PAPER_REPORTS)}")
