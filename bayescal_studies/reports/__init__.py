"""The committed reports' renderers: text and figures rendered from findings, never computed here.

``geometry``, ``twin`` and ``elastostatic`` render the findings of
:mod:`bayescal_studies.studies.geometry_findings`, :mod:`~bayescal_studies.studies.twin_findings` and
:mod:`~bayescal_studies.studies.elastostatic_findings` into their files (name to bytes), ``paper``
dispatches on the kind of findings and ``detection`` renders the detection report; they draw with
:mod:`bayescal.reports.plots` and write nothing themselves.
"""
