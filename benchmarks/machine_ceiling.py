"""What two threads can gain on this machine at all, for each kind of work a DEM step does.

Usage: python benchmarks/machine_ceiling.py [--rounds 5]

Each kernel below does the same fixed amount of work per thread; run on one thread, then on two
threads at once (each its own copy of the work), the ratio 2·t(1)/t(2) is the speed-up two
threads can reach for that kind of work (2.0: two independent cores; ~1.0: the two threads
share one resource that the kernel saturates):

- ``latency-bound FP``: one dependent chain of multiply-adds (uses a fraction of a core's
  execution units; even two hyperthreads of one core would each run at full speed);
- ``throughput-bound FP``: eight independent chains of square roots and divisions, the
  arithmetic of a live contact (saturates a core's divider: hyperthreads sharing one core
  would share it);
- ``L2-resident read``: sums over 256 KiB per thread, repeated (the private caches);
- ``DRAM read``: sums over 256 MiB per thread, once (memory bandwidth, shared by the cores);
- ``random gather``: reads at random indices of a 64 MiB array per thread (memory latency, as
  the gather of a large particle system).

Best of ``--rounds`` per kernel and thread count. Compare a kernel's ratio with the two-thread
speed-up of a simulator component (``benchmarks/profile_step.py``) to see which resource
limits it.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numba
import numpy as np
from numba import njit, prange

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from sim.threads import configure_threading  # noqa: E402


@njit(cache=True)
def _latency_fp(n, seed):
    x = seed
    for _ in range(n):
        x = x * 0.9999999 + 1e-7
    return x


@njit(cache=True)
def _throughput_fp(n, seed):
    a = np.empty(8)
    for c in range(8):
        a[c] = seed + c
    for _ in range(n):
        for c in range(8):
            a[c] = math.sqrt(a[c] + 1.0) / 1.0000001 + 0.5
    return a.sum()


@njit(cache=True)
def _read(a, repeats):
    s = 0.0
    for _ in range(repeats):
        for k in range(a.shape[0]):
            s += a[k]
    return s


@njit(cache=True)
def _gather(a, idx):
    s = 0.0
    for k in range(idx.shape[0]):
        s += a[idx[k]]
    return s


@njit(cache=True, parallel=True)
def _on_threads(kind, n, arrays, indices, repeats, n_threads):
    """Run the kernel ``kind`` once per thread, each on its own data; returns the results."""
    out = np.empty(n_threads)
    for t in prange(n_threads):
        if kind == 0:
            out[t] = _latency_fp(n, 1.0 + t)
        elif kind == 1:
            out[t] = _throughput_fp(n, 1.0 + t)
        elif kind == 2:
            out[t] = _read(arrays[t], repeats)
        else:
            out[t] = _gather(arrays[t], indices[t])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    configure_threading()
    cores = numba.config.NUMBA_NUM_THREADS
    threads = min(2, cores)
    rng = np.random.default_rng(0)
    l2 = np.ones((threads, 32 * 1024))  # 256 KiB each
    dram = np.ones((threads, 32 * 1024 * 1024))  # 256 MiB each
    big = np.ones((threads, 8 * 1024 * 1024))  # 64 MiB each
    idx = rng.integers(0, big.shape[1], size=(threads, 4 * 1024 * 1024))
    none = np.zeros((threads, 1))
    no_idx = np.zeros((threads, 1), dtype=np.int64)
    kernels = [
        ("latency-bound FP", 0, 50_000_000, none, no_idx, 1),
        ("throughput-bound FP", 1, 5_000_000, none, no_idx, 1),
        ("L2-resident read", 2, 0, l2, no_idx, 2000),
        ("DRAM read", 2, 0, dram, no_idx, 1),
        ("random gather", 3, 0, big, idx, 1),
    ]
    print(f"numba {numba.__version__}, {cores} cores; best of {args.rounds}")
    print(f"{'kernel':<22}{'1 thread [ms]':>15}{'2 threads [ms]':>16}{'2-thread speed-up':>19}")
    for name, kind, n, arrays, indices, repeats in kernels:
        best = {}
        for t in (1, threads):
            numba.set_num_threads(t)
            _on_threads(kind, min(n, 1000), arrays, indices, 1, t)  # compile, touch the pages
            best[t] = min(_timed(lambda: _on_threads(kind, n, arrays, indices, repeats, t)) for _ in range(args.rounds))
        print(f"{name:<22}{best[1] * 1e3:>15.1f}{best[threads] * 1e3:>16.1f}{threads * best[1] / best[threads]:>19.2f}",
              flush=True)


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
