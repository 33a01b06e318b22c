"""The digital twin: simulated calibration campaigns with known truth.

Owns the simulator (``simulator``) and the effects it can plant in a campaign that
the identification model does not contain (``effects``), and a second generator
written apart from both (``independent``), to check methods on data they were not
built from.
"""
