"""The digital twin: simulated calibration campaigns with known truth.

Owns the simulator (``simulator``) and the effects it can plant in a campaign that
the identification model does not contain (``effects``), a second generator
written apart from both (``independent``) and a third written apart from all of them
(``beams``: links as beams, a hinged tool mount, a tracker with its own clock, noise and
reference nests; ``docs/generators.md``), to check methods on data they were not built from.
"""
