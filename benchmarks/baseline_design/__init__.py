"""BASELINE: the plan designer before batched equilibria, kept verbatim (imports aside) for ``bench_design.py``.

``criteria.py``, ``constraints.py``, ``loads.py``, ``optimise.py`` and ``discriminate.py`` of ``bayescal.design`` as they were
when the exact criteria still solved one configuration's equilibria at a time: the benchmark times them
against the package in the same run and checks that both design the same plans for the same seed.
"""
