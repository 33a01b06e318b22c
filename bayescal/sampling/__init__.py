"""Samplers and posterior summaries.

Owns the sampler protocol (``protocol``), emcee ensembles (``ensemble``), the Gibbs sampler of the
linear-Gaussian deflection model (``gibbs``), the default sampler of that model, with the linear
coefficients integrated out and batched independence proposals for the rest (``collapsed``), independence Metropolis-Hastings with a Laplace
proposal (``independence``), R-hat and ESS (``diagnostics``) and the DataTree summaries and
files (``summary``).
"""
