"""numba's threads on OpenMP, for the programs (the ``granalytics`` command line, ``python -m sim``,
a sweep's point runner): never called by the library, which leaves the process as it finds it
(docs/simulator.md, "Threads")."""

from __future__ import annotations

import os

__all__ = ["THREADING_LAYER_PRIORITY", "GOMP_SPINCOUNT", "prefer_openmp"]

#: numba's threading layers, first choice first: OpenMP starts a parallel region in microseconds,
#: TBB (numba's own first choice where installed) in ~0.5 ms
THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]
#: how often an idle OpenMP thread spins before it sleeps; with OpenMP's default two processes
#: sharing the cores slow each other ~100x
GOMP_SPINCOUNT = "3000"


def prefer_openmp() -> str | None:
    """Put this process's numba kernels on OpenMP threads spinning :data:`GOMP_SPINCOUNT` times
    (unless the environment sets it), before numba starts any thread. Returns the layer numba
    already runs on when its threads were started earlier (then nothing can change), else None."""
    import numba

    try:
        return numba.threading_layer()
    except ValueError:  # threads not launched yet
        pass
    numba.config.THREADING_LAYER_PRIORITY = list(THREADING_LAYER_PRIORITY)
    os.environ.setdefault("GOMP_SPINCOUNT", GOMP_SPINCOUNT)
    return None
