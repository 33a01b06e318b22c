"""Studies: what a plan, a campaign or a model can deliver, each a function returning a table.

Every Monte-Carlo or precision study lives here, named after what it computes;
the reports render their tables and word their claims from them.  ``precision``
holds the eq-37 precision of a plan, effect detectability, the compensator's
precision after a fit and the band of Fig. 7; ``balance`` the compensator
against the arm's weight; ``linearisation`` the linear model's misfit on
nonlinear campaigns; ``sensitivity`` the exact model's dependence on its
assumed masses and spring;
``arc_fit`` and ``geometry_coverage`` the geometry fits and posterior on
simulated Table I campaigns; ``cylinder_markers`` what Table I's cylinder
markers fix; ``elastostatic_coverage`` the identification's intervals on twin
campaigns unlike the config; ``plans`` the test-pose error plans leave over
simulated campaigns and ``angles`` what each extra q2 angle buys;
``parallel`` runs any of them on an executor.  ``geometry_findings``,
``twin_findings`` and ``elastostatic_findings`` compute every number and verdict
of the committed reports (``paper_reports`` names their sources and seeds),
``review`` what the review page shows of a calibration.
"""
