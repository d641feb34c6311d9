"""Process-wide set-up for the numba kernels' threads, applied only by the programs (the command
lines and the simulator), never at import."""

from __future__ import annotations

import os

__all__ = ["configure_threading"]

#: what :func:`configure_threading` sets (docs/simulator.md, "Threads")
THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]
GOMP_SPINCOUNT = "3000"


def configure_threading() -> None:
    """Set up the process for the simulator's parallel kernels; a no-op once numba has started
    its threads (the threading layer and OpenMP's settings are fixed from then on).

    - numba's threading layer priority becomes OpenMP first: its parallel regions start in
      microseconds, TBB's take ~0.5 ms, which dominates a time step of a few thousand
      particles (falls back to TBB, then workqueue, when OpenMP is absent);
    - ``GOMP_SPINCOUNT`` is set to 3000 unless already set: idle OpenMP threads spin before
      sleeping, and with the default spin count two processes sharing the cores slow each other
      down ~100x.

    Called by both command lines (``granalytics``, ``python -m sim``) and by
    :class:`sim.Simulation` (creating or running one); importing granalytics or sim changes no
    global state.
    """
    import numba

    try:
        numba.threading_layer()
        return  # threads already launched: too late to change anything
    except ValueError:
        pass
    numba.config.THREADING_LAYER_PRIORITY = list(THREADING_LAYER_PRIORITY)
    os.environ.setdefault("GOMP_SPINCOUNT", GOMP_SPINCOUNT)
