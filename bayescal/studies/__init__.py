"""Studies: what a plan, a campaign or a model can deliver, each a function returning a table.

``precision`` holds the eq-37 precision of a plan and the detectability of planted effects.
"""
