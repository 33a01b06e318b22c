"""Reports: text and figures rendered from results, never computed here.

``review`` renders the calibration review (with ``review_data``, ``review_files``,
``review_parameters``, ``compensation``, ``test_pose`` and ``ladder``), on ``page``;
``plots`` and ``figures`` draw the figures; ``bayescal report`` writes them all
through :mod:`bayescal.output`.  The paper's committed reports are rendered by
:mod:`bayescal_studies.reports`, which uses these and is never used by them.
"""
