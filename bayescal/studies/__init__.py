"""Studies: what a plan, a campaign or a model can deliver, each a function returning a table.

``precision`` holds the eq-37 precision of a plan and the detectability of planted effects,
``plans`` the test-pose error plans leave over simulated campaigns, and ``angles`` what
each extra q2 angle buys.
"""
