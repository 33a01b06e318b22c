"""Studies: what a plan, a campaign or a model can deliver over many simulated campaigns, each a function returning a table.

Every Monte-Carlo validation or precision study of the method lives here, named
after what it computes; the paper reports render their tables and word their
claims from them.  ``precision`` holds the eq-37 precision of a plan, effect
detectability and the compensator's precision after a fit; ``balance`` the
compensator against the arm's weight; ``linearisation`` the linear model's
misfit on nonlinear campaigns; ``sensitivity`` the exact model's dependence on
its assumed masses and spring; ``arc_fit`` and ``geometry_coverage`` the
geometry fits and posterior on simulated Table I campaigns; ``cylinder_markers``
what Table I's cylinder markers fix; ``elastostatic_coverage`` the
identification's intervals on twin campaigns unlike the config; ``plans`` the
test-pose error plans leave over simulated campaigns.  They run on any executor
through :func:`bayescal.design.parallel.seeded_map`.  ``geometry_findings``,
``twin_findings`` and ``elastostatic_findings`` compute every number and verdict
of the committed reports (``paper_reports`` names their sources and seeds).
What a user runs on their own cell is the product's: the q2-angle study
(:mod:`bayescal.design.angles`), the residual table
(:mod:`bayescal.inference.residuals`), Fig. 7's band
(:mod:`bayescal.inference.compliance_band`) and what the review shows of a
calibration (:mod:`bayescal.compensation.review`).
"""
