"""GNA wall time per graph backend on a paper-scale synthetic frame.

Usage: python benchmarks/identify.py [--particles 120000] [--contacts-per-particle 2.5]

Each backend runs in a fresh child process that builds the same synthetic frame
(granalytics.datasets.synthetic, physics-free, ~300 000 contacts for 120 000 particles), warms up the
numba kernels on a tiny frame, resets the kernel's peak-RSS counter, then times
``identify(frame, backend=...)`` (filter + connected components + canonical labels + sizes).
"peak MiB" is the peak resident memory of one more call above the level before it, measured after
the timing with glibc's mmap threshold fixed low so that freed arrays leave the resident set. The networkx
backend is the paper's pipeline (filter contacts, build an nx.Graph, BFS components) and is the
baseline of the ratio column, measured in the same run.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import subprocess
import sys
import time


def _rss_kib(field):
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return 0


def child(backend, threads, particles, contacts_per_particle, repeats):
    import numba
    import numpy as np

    import granalytics as ga
    from granalytics.base.threads import prefer_openmp
    from granalytics.datasets.synthetic import synthetic_snapshot

    prefer_openmp()  # as the granalytics command line does, before numba starts its threads
    numba.set_num_threads(threads)
    frame = synthetic_snapshot(particles, contacts_per_particle=contacts_per_particle, seed=1)
    ga.identify(synthetic_snapshot(50, seed=0), backend=backend)  # compile / load the kernels
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = ga.identify(frame, backend=backend)
        times.append(time.perf_counter() - t0)
    # memory, after timing: make large blocks mmapped (returned to the OS on free), so the
    # peak-RSS reading is not hidden by heap memory freed while building the frame
    libc = ctypes.CDLL("libc.so.6")
    libc.mallopt(-3, 128 * 1024)  # M_MMAP_THRESHOLD
    libc.malloc_trim(0)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # reset VmHWM to the current RSS
    except OSError:
        pass
    base = _rss_kib("VmRSS")
    ga.identify(frame, backend=backend)
    peak = _rss_kib("VmHWM")
    print(json.dumps({
        "backend": backend, "threads": threads, "particles": frame.n_particles, "contacts": frame.n_contacts,
        "median_ms": 1e3 * float(np.median(times)), "min_ms": 1e3 * min(times),
        "peak_mib": max(peak - base, 0) / 1024, "granules": result.n_granules, "kept": int(result.kept.sum()),
        "labels_hash": int(np.bitwise_xor.reduce(result.labels * np.arange(1, frame.n_particles + 1))),
    }))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=120_000)
    parser.add_argument("--contacts-per-particle", type=float, default=2.5)
    parser.add_argument("--child", nargs=2, metavar=("BACKEND", "THREADS"), help=argparse.SUPPRESS)
    parser.add_argument("--repeats", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], int(args.child[1]), args.particles, args.contacts_per_particle, args.repeats)
        return
    import numba

    cores = numba.config.NUMBA_NUM_THREADS
    plan = [("networkx", cores, 3), ("igraph", cores, 5), ("scipy", cores, 30), ("fast", 1, 50), ("fast", cores, 50)]
    rows = []
    for backend, threads, repeats in plan:
        out = subprocess.run(
            [sys.executable, __file__, "--child", backend, str(threads), "--repeats", str(repeats),
             "--particles", str(args.particles), "--contacts-per-particle", str(args.contacts_per_particle)],
            capture_output=True, text=True, check=True,
        )
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
    base = next(r for r in rows if r["backend"] == "networkx")["median_ms"]
    first = rows[0]
    print(f"GNA per frame: {first['particles']} particles, {first['contacts']} contacts, "
          f"{first['kept']} kept (C_agg = 0.6, A_agg = 20°), {cores} cores")
    print(f"{'backend':<10}{'threads':>8}{'median ms':>12}{'min ms':>10}{'× networkx':>12}{'peak MiB':>10}{'granules':>10}")
    for r in rows:
        print(f"{r['backend']:<10}{r['threads']:>8}{r['median_ms']:>12.2f}{r['min_ms']:>10.2f}"
              f"{base / r['median_ms']:>12.1f}{r['peak_mib']:>10.1f}{r['granules']:>10}")
    same = len({(r["granules"], r["kept"], r["labels_hash"]) for r in rows}) == 1
    print("identical labels across backends:", "yes" if same else "NO")
    if not same:
        sys.exit(1)


if __name__ == "__main__":
    main()
