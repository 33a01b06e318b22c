"""Elastostatic identification (Klimchik et al., section V, eqs 30-35 and 38-39).

Owns the deflection equations, the closed form, the exact model and the model and
results classes (``elastostatic``), the likelihoods (``likelihood``), what a campaign
can identify (``identifiability``) and the accuracy at the test pose (``testpose``).
"""
