"""Reports: text and figures rendered from findings, never computed here.

``geometry``, ``twin`` and ``elastostatic`` render the findings of
:mod:`bayescal.studies.geometry_findings`, :mod:`~bayescal.studies.twin_findings` and
:mod:`~bayescal.studies.elastostatic_findings` into their files (name to bytes), ``paper``
dispatches on the kind of findings, ``review`` renders the calibration review and ``plots``
and ``figures`` draw the figures; ``bayescal report`` writes them all through
:mod:`bayescal.output`.
"""
