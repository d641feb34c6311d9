"""The thread count of the simulator's kernels: fixed, or chosen as the run goes (``"auto"``).

Every parallel region of a time step ends at a barrier, so a thread that the operating system
deschedules (another program wants the core) stalls the others until it runs again: on a busy
2-core machine a 111-particle drum ran 20 times slower on two threads than on one. The
simulator's results are bit-identical for any thread count, so the count can change between any
two kernel calls without changing the trajectory: :class:`ThreadGovernor` measures the rate at
each candidate count for a short probe, runs on the fastest and measures again every
``recheck_s`` seconds, or at once when the rate falls (docs/simulator.md, "Threads").

:func:`configure_threading` sets the process up for the kernels (OpenMP first, its spin count,
glibc's freed memory kept); only the programs call it, never an import or a :class:`Simulation`.
"""

from __future__ import annotations

import ctypes
import functools
import os
import time
import warnings

from granalytics.base.threads import THREADING_LAYER_PRIORITY, prefer_openmp

__all__ = ["ThreadGovernor", "available_cores", "thread_candidates", "check_threads", "configure_threading"]

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

    Called by the command line (``python -m sim run``) and by a sweep's point runner in its
    worker processes (:func:`sim.sweep.run_point`); importing sim or creating and running a
    :class:`sim.run.Simulation` changes no process state, so a program that runs simulations
    through the library calls this first (docs/simulator.md, "Threads").
    """
    import numba

    global _warned_late
    _keep_freed_memory()
    layer = prefer_openmp()
    if layer is not None:  # too late to change anything
        chosen_by_us = list(numba.config.THREADING_LAYER_PRIORITY) == THREADING_LAYER_PRIORITY
        if layer != "omp" and not chosen_by_us and not _warned_late:
            _warned_late = True
            warnings.warn(
                f"numba's threads were started before sim.threads.configure_threading() and use its {layer!r} "
                "layer, whose parallel regions start ~100x slower than OpenMP's: the simulator's small systems "
                "run many times slower. Call configure_threading() before numba.set_num_threads() or any "
                "parallel kernel.", RuntimeWarning, stacklevel=2)


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


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity, e.g. a cluster job's share of a node)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no sched_getaffinity (macOS, Windows)
        return os.cpu_count() or 1


def check_threads(value, name="threads"):
    """``value`` if it is ``"auto"``, ``None`` or a whole number in [1, ``NUMBA_NUM_THREADS``];
    else a ``ValueError`` naming ``name`` (the attribute, or the command line's option)."""
    import numba

    if value in ("auto", None) or (isinstance(value, int) and not isinstance(value, bool)
                                   and 1 <= value <= numba.config.NUMBA_NUM_THREADS):
        return value
    raise ValueError(f"{name} must be 'auto' or a whole number in [1, {numba.config.NUMBA_NUM_THREADS}], got {value!r}")


def thread_candidates(max_threads: int) -> list[int]:
    """The thread counts the governor tries: 1, 2, 4, … below ``max_threads``, and ``max_threads``."""
    counts, k = [], 1
    while k < max_threads:
        counts.append(k)
        k *= 2
    return counts + [max_threads]


class ThreadGovernor:
    """Chooses numba's thread count for each kernel call of a simulation by measuring.

    A *probe* runs each candidate count (:func:`thread_candidates`) for ``probe_s`` seconds of
    wall time, in ``probe_slices`` interleaved slices (1, 2, 1, 2, …: on a machine whose other
    load comes and goes, counts measured one after the other would compare different moments),
    and keeps the count with the highest rate (particle-steps per second over its slices; of counts
    within ``prefer`` of each other, the smallest). The run then
    goes on at that count, measured in windows of ``window_s``; a new probe starts
    ``first_recheck_s`` seconds after a probe that changed the count, twice as long after one
    that kept it, up to ``recheck_s`` (so that a choice made in a moment of passing load is
    soon corrected, and a settled one costs little), or after the first window whose rate is
    below ``fall`` times the rate the count was chosen at (the load changed) — unless the count
    is already the fewest: more threads do not help a machine that got busier, and each probe of
    them costs the time they stall (the periodic rechecks still find a machine that got
    freer). When the chosen count's rate drops below half the
    highest rate of the run, one warning says so, with the load average.

    Parameters
    ----------
    max_threads : int, optional
        The most threads to use; default: the cores of the process's affinity, at most numba's
        thread pool (``NUMBA_NUM_THREADS``).
    probe_s, window_s : float
        Probe length per candidate and measurement window [s].
    probe_slices : int
        Slices each candidate's probe time is cut into, interleaved with the others'.
    first_recheck_s, recheck_s : float
        Shortest and longest time between probes [s].
    fall : float
        Fraction of the chosen rate below which a window starts a new probe.
    prefer : float
        A probe keeps the fewest threads whose rate is within this factor of the fastest: fewer
        threads lose less when the load rises (and leave the cores to others) and a rate
        measured in a short probe is uncertain by some per cent.
    call_s : float
        Target wall time of one kernel call [s]: :meth:`begin` caps the steps of a call so that
        probes and windows can end on time, from the last call at the same count (a count's
        first call does one step: a count can be 20 times slower than another).
    clock : callable
        Wall clock [s] (``time.perf_counter``; replaceable for tests).
    """

    def __init__(self, max_threads: int | None = None, *, probe_s: float = 0.3, probe_slices: int = 3,
                 window_s: float = 0.5,
                 first_recheck_s: float = 2.0, recheck_s: float = 20.0, fall: float = 0.7, prefer: float = 1.1,
                 call_s: float = 0.05, clock=time.perf_counter):
        import numba

        limit = min(available_cores(), numba.config.NUMBA_NUM_THREADS)
        self.max_threads = limit if max_threads is None else max(1, min(int(max_threads), limit))
        self.candidates = thread_candidates(self.max_threads)
        self.probe_s, self.window_s, self.call_s = probe_s, window_s, call_s
        self.probe_slices = max(1, int(probe_slices))
        self.first_recheck_s, self.recheck_s = first_recheck_s, recheck_s
        self._interval = first_recheck_s  # time to the next probe
        self.fall, self.prefer = fall, prefer
        self._clock = clock
        self.rates: dict[int, float] = {}  # particle-steps/s of each count at its latest probe
        self.threads = self.max_threads
        self.chosen_rate = 0.0  # the rate at which self.threads was chosen
        self._chosen = self.max_threads
        self.best_rate = 0.0  # the highest window rate of the run
        self.history: list[tuple[int, float]] = []  # (threads, rate) of every finished window
        self._queue = self._probe_order(first=None)  # probe slices still to run; empty: running on the chosen one
        self._probe_work: dict[int, float] = {}  # particle-steps and wall time of each count in this probe
        self._probe_wall: dict[int, float] = {}
        self._start_probe_at = None
        self._warned = False
        self._window_work = self._window_wall = 0.0
        self._steps_per_call: dict[int, int] = {}  # per count: a count's first call is one step
        self._calls = 0

    def _probe_order(self, first):
        """The slices of a probe: every candidate once per round, ``probe_slices`` rounds; the
        count running now (``first``) ends each round, so that a probe starts with a change."""
        counts = [c for c in self.candidates if c != first] + ([first] if first in self.candidates else [])
        return counts * self.probe_slices

    @property
    def probing(self) -> bool:
        """Whether a probe is under way."""
        return bool(self._queue)

    def begin(self, n_particles: int, remaining: int) -> int:
        """Set numba's thread count for the next kernel call; returns the most steps it should do."""
        import numba

        if not self._queue and self._start_probe_at is not None and self._clock() >= self._start_probe_at:
            self._queue = self._probe_order(first=self.threads)
            self._window_work = self._window_wall = 0.0
        if self._queue:
            self.threads = self._queue[0]
        numba.set_num_threads(self.threads)
        return max(1, min(remaining, self._steps_per_call.get(self.threads, 1)))

    def end(self, steps: int, n_particles: int, wall_s: float) -> None:
        """Account for a kernel call (and the rebuild after it) of ``steps`` steps of
        ``n_particles`` particles that took ``wall_s`` seconds. The first call is not measured
        (it may load or compile the kernels)."""
        self._calls += 1
        if self._calls == 1:
            return
        if steps > 0 and wall_s > 0:  # the next call's length from this one's speed, growing at most 4x a call
            last = self._steps_per_call.get(self.threads, 1)
            self._steps_per_call[self.threads] = max(1, min(4 * last, int(self.call_s * steps / wall_s)))
        self._window_work += steps * n_particles
        self._window_wall += wall_s
        if self._window_wall < (self.probe_s / self.probe_slices if self._queue else self.window_s):
            return
        rate = self._window_work / self._window_wall
        if self._queue:
            self._probe_work[self.threads] = self._probe_work.get(self.threads, 0.0) + self._window_work
            self._probe_wall[self.threads] = self._probe_wall.get(self.threads, 0.0) + self._window_wall
        self._window_work = self._window_wall = 0.0
        self.history.append((self.threads, rate))
        self.best_rate = max(self.best_rate, rate)
        if self._queue:
            self._queue.pop(0)
            if not self._queue:  # probe done: the fewest threads within `prefer` of the fastest
                for c in self.candidates:
                    if self._probe_wall.get(c):
                        self.rates[c] = self._probe_work[c] / self._probe_wall[c]
                self._probe_work.clear()
                self._probe_wall.clear()
                fastest = max(self.rates.get(c, 0.0) for c in self.candidates)
                chosen = min(c for c in self.candidates if self.prefer * self.rates.get(c, 0.0) >= fastest)
                kept = self.chosen_rate > 0 and chosen == self._chosen
                self._interval = min(2 * self._interval, self.recheck_s) if kept else self.first_recheck_s
                self.threads = self._chosen = chosen
                self.chosen_rate = self.rates[chosen]
                self._start_probe_at = self._clock() + self._interval
            return
        if rate < self.fall * self.chosen_rate and self.threads > self.candidates[0]:
            self._start_probe_at = self._clock()  # the load changed: probe again now
        if rate < 0.5 * self.best_rate and not self._warned:
            self._warned = True
            load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
            warnings.warn(
                f"the simulator slowed to {rate / 1e6:.2f}M particle-steps/s from {self.best_rate / 1e6:.2f}M earlier "
                f"in the run: the machine is busy (load average {load:.1f} on {available_cores()} cores); running on "
                f"{self.threads} thread(s), the fastest now", RuntimeWarning, stacklevel=2)
