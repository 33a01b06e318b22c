"""Samplers and posterior summaries.

Owns the sampler protocol and emcee ensembles (``ensemble``), the Gibbs sampler of the
linear-Gaussian deflection model (``gibbs``) and the ArviZ DataTree summaries,
diagnostics and files (``summary``).
"""
