"""Process-wide set-up for the numba kernels' threads, applied only by the programs (the command
lines and the simulator), never at import."""

from __future__ import annotations

import ctypes
import functools
import os
import warnings

__all__ = ["configure_threading"]

#: what :func:`configure_threading` sets (docs/simulator.md, "Threads")
THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]
GOMP_SPINCOUNT = "3000"
_warned_late = False


def configure_threading() -> None:
    """Set up the process for the simulator's parallel kernels. The threading part can only act
    before numba starts its threads (the layer and OpenMP's settings are fixed from then on);
    called later, it warns (once) if numba chose another layer than OpenMP without this set-up,
    e.g. because ``numba.set_num_threads`` was called first.

    - numba's threading layer priority becomes OpenMP first: its parallel regions start in
      microseconds, TBB's take ~0.5 ms, which dominates a time step of a few thousand
      particles (falls back to TBB, then workqueue, when OpenMP is absent);
    - ``GOMP_SPINCOUNT`` is set to 3000 unless already set: idle OpenMP threads spin before
      sleeping, and with the default spin count two processes sharing the cores slow each other
      down ~100x;
    - freed memory stays in the process (glibc only: ``mallopt`` with no mmap-backed blocks and
      no trimming): otherwise each neighbour-list rebuild's new slot arrays, above glibc's
      32 MB limit for reusing freed blocks at 120 000 particles (~400 MB per rebuild), come
      fresh from the kernel and every page faults on first touch. Allocating and writing
      245 MB took 48 ms with fresh pages and 20 ms with reused ones on the development
      machine. The price is that the process keeps its peak heap until it exits.

    Called by both command lines (``granalytics``, ``python -m sim``) and by
    :class:`sim.Simulation` (creating or running one); importing granalytics or sim changes no
    global state.
    """
    import numba

    global _warned_late
    _keep_freed_memory()
    try:
        layer = numba.threading_layer()
    except ValueError:
        layer = None  # threads not launched yet
    if layer is not None:  # too late to change anything
        chosen_by_us = list(numba.config.THREADING_LAYER_PRIORITY) == THREADING_LAYER_PRIORITY
        if layer != "omp" and not chosen_by_us and not _warned_late:
            _warned_late = True
            warnings.warn(
                f"numba's threads were started before granalytics.configure_threading() and use its {layer!r} "
                "layer, whose parallel regions start ~100x slower than OpenMP's: the simulator's small systems "
                "run many times slower. Call configure_threading() before numba.set_num_threads() or any "
                "parallel kernel.", RuntimeWarning, stacklevel=2)
        return
    numba.config.THREADING_LAYER_PRIORITY = list(THREADING_LAYER_PRIORITY)
    os.environ.setdefault("GOMP_SPINCOUNT", GOMP_SPINCOUNT)


_M_TRIM_THRESHOLD = -1
_M_MMAP_MAX = -4


@functools.cache
def _keep_freed_memory() -> None:
    """glibc's malloc: serve every block from the heap and never return freed memory to the
    OS (see :func:`configure_threading`); nothing on other C libraries. Once per process."""
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION").startswith("glibc"):
            return
        libc = ctypes.CDLL("libc.so.6")
    except (ValueError, OSError, AttributeError):  # not glibc, or no confstr (Windows)
        return
    libc.mallopt(_M_MMAP_MAX, 0)
    libc.mallopt(_M_TRIM_THRESHOLD, 2**31 - 1)
