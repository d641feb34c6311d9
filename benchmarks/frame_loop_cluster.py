"""The frame loop on threads and on a dask cluster: run_stats (GNA, the paper's thresholds) over a
synthetic run of 120 000 particles, serially, on 2 threads and on a local dask cluster of 2 worker
processes, best of 3 each (alternating), with the speed-up against the serial time of the same run.

    python benchmarks/frame_loop_cluster.py [--particles 120000] [--frames 8] [--repeats 3]

The cluster's start (worker processes, imports, numba compilation on each worker) is timed apart
and not in the per-loop times: a cluster is started once for many analyses.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import pandas as pd  # noqa: E402

import granalytics as ga  # noqa: E402
from granalytics.datasets.synthetic import write_synthetic_run  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=120_000)
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    from distributed import Client, LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "synthetic.h5")
        write_synthetic_run(path, args.particles, revolutions=args.frames / 20, frames_per_revolution=20)
        with ga.open_run(path) as run:
            frames = run.select(revolutions=(0.0, 1e9))
            n_frames = len(frames)
            reference = ga.run_stats(frames)  # compiles the kernels here
            t0 = time.perf_counter()
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                              silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
                ga.run_stats(frames, scheduler=client)  # workers import and compile
                start_s = time.perf_counter() - t0
                modes = {"serial": {}, "2 threads": {"jobs": 2}, "dask, 2 workers": {"scheduler": client}}
                best = {name: float("inf") for name in modes}
                for _ in range(args.repeats):
                    for name, kwargs in modes.items():
                        t = time.perf_counter()
                        table = ga.run_stats(frames, **kwargs)
                        best[name] = min(best[name], time.perf_counter() - t)
                        pd.testing.assert_frame_equal(table, reference)  # the same numbers whatever runs them
    load = os.getloadavg()
    print(f"run_stats over {n_frames} frames of {args.particles} particles, best of {args.repeats}; "
          f"load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}; cluster start {start_s:.1f} s")
    print("| loop | s | s per frame | speed-up |")
    print("| --- | --- | --- | --- |")
    for name, t in best.items():
        print(f"| {name} | {t:.2f} | {t / n_frames:.3f} | {best['serial'] / t:.2f} |")


if __name__ == "__main__":
    main()
