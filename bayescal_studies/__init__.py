"""bayescal_studies: the research beside bayescal, never imported by it.

The Monte-Carlo validation studies and the findings of the committed reports
(:mod:`bayescal_studies.studies`), their renderers (:mod:`bayescal_studies.reports`)
and the command that regenerates ``reports/`` (``python -m bayescal_studies
reports``, :mod:`bayescal_studies.cli`).  Everything here depends on
:mod:`bayescal`; nothing in :mod:`bayescal` depends on it (``tests/test_layers.py``).
"""
