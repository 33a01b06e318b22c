"""The committed reports' renderers, by the kind of findings they render.

Each renderer returns its files (name to content); ``python -m bayescal_studies reports DIR``
writes them all through :func:`bayescal.output.write_folder`.
"""

from __future__ import annotations

from bayescal_studies.reports import elastostatic, geometry, twin
from bayescal_studies.studies.elastostatic_findings import ElastostaticFindings
from bayescal_studies.studies.geometry_findings import GeometryFindings
from bayescal_studies.studies.twin_findings import TwinFindings

__all__ = ["PAPER_REPORT_FILES", "render_paper_report"]

PAPER_REPORT_FILES = {
    "geometry": (geometry.REPORT_FILE, geometry.ARCS_FIGURE, geometry.ETA_FIGURE),
    "twin": (twin.REPORT_FILE,),
    "elastostatic": (elastostatic.REPORT_FILE, elastostatic.FIGURE_FILE),
    "detection": ("detection.md",),
}
"""The files each committed report writes (the output guard checks them before any work)."""


def render_paper_report(findings: GeometryFindings | TwinFindings | ElastostaticFindings) -> dict[str, bytes]:
    """The files of the report of ``findings``: Markdown and figures, by name."""
    if isinstance(findings, GeometryFindings):
        return geometry.render_geometry(findings)
    if isinstance(findings, TwinFindings):
        return twin.render_twin(findings)
    if isinstance(findings, ElastostaticFindings):
        return elastostatic.render_elastostatic(findings)
    raise TypeError(f"no report renders {type(findings).__name__}")
