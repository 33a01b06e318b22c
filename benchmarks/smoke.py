"""The benchmarks' smoke size: ``BAYESCAL_BENCH_SMOKE=1`` runs every step of a script once, at a tiny size.

The numbers it prints mean nothing; the run only shows that the script still
works with the package as it is (``tests/benchmarks/test_smoke.py`` runs every
``bench_*.py`` so, so that a renamed function cannot break one silently).
"""

from __future__ import annotations

import os

SMOKE = os.environ.get("BAYESCAL_BENCH_SMOKE") == "1"
"""True when the benchmarks run at their smoke size."""


def sized(full, tiny):
    """``full``, or ``tiny`` at the smoke size."""
    return tiny if SMOKE else full


SAMPLER = sized({}, dict(n_chains=2, n_tune=20, n_draws=40))
"""Options of a benchmark's samplers: their defaults, or a few draws at the smoke size."""
