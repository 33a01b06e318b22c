"""One BLAS thread while bayescal computes, BLAS's own setting again once it returns.

Every matrix of a fit is a few columns wide (a dozen compliances, eleven nonlinear
coordinates, stacks of 6 × 6 Jacobians), so BLAS threads only add their start-up and
spinning; on a shared machine they spin against the other processes.  The command line
sets ``OPENBLAS_NUM_THREADS=1`` before NumPy loads, which a user's script does not: a fit
called from Python (:meth:`ElastostaticModel.fit
<bayescal.inference.elastostatic.ElastostaticModel.fit>`, :meth:`GeometryPosteriorModel.fit
<bayescal.geometry.posterior.GeometryPosteriorModel.fit>`) limits BLAS to one thread
itself, for its own duration only (``benchmarks/bench_threads.py`` measures both).

The limit is set and lifted from the main thread only.  OpenBLAS's pool is shared by
the whole process, and once the main thread has set its size, OpenBLAS (0.3.34, NumPy's
wheel) ignores a size set from any other thread: a limit set and lifted there could not
be relied on either way.  A fit run in another thread (a thread-pool executor, a
``dask.distributed`` worker) leaves BLAS as it finds it; a process pool's workers run
their fits in their main threads, limited.  BLAS calls of the user's other threads
during a fit run on one thread too.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

# The controller lists the BLAS libraries loaded when it is made (0.7 ms: it walks the process's shared
# libraries); an import can load another (scipy.linalg its own OpenBLAS), so it is made again when the
# number of imported modules has changed since, and reused otherwise.
_controller: ThreadpoolController | None = None
_modules_seen = -1


def _current_controller() -> ThreadpoolController:
    global _controller, _modules_seen
    if _controller is None or len(sys.modules) != _modules_seen:
        _controller, _modules_seen = ThreadpoolController(), len(sys.modules)
    return _controller


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Limit every loaded BLAS library to one thread inside the block, called from the main thread; restore the limits found on leaving."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _current_controller().limit(limits=1, user_api="blas"):
        yield
