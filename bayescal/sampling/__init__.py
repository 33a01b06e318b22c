"""Samplers and posterior summaries.

Owns the sampler protocol (``protocol``), emcee ensembles (``ensemble``), the Gibbs sampler of the
linear-Gaussian deflection model (``gibbs``), independence Metropolis-Hastings with a Laplace
proposal (``independence``), R-hat and ESS (``diagnostics``) and the DataTree summaries and
files (``summary``).
"""
