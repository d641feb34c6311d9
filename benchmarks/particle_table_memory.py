"""Memory of the tidy per-particle table (``granalytics.particle_table``, ``granalytics table``).

Usage: python benchmarks/particle_table_memory.py [RUN ...] [--window 3:6] [--synthetic N_PARTICLES ...]

For each run (a file, or a physics-free run of N particles written to a temporary folder with 61
frames, the frames of the steady window [3, 6] of a run written every 0.05 revolution), over the
frames of ``--window``: the rows, the DataFrame's own size (``memory_usage(deep=True)``), the peak
of Python-traced memory while :func:`particle_table` builds it (numpy and pandas allocations
included; ``tracemalloc``), the same peak for the streamed path of ``granalytics table``
(:func:`granalytics.analysis.particle_tables.particle_frames`, one frame's table at a time, written to Parquet by
:func:`granalytics.report.files.stream_table`), and
the wall time of each. Prints a table.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import tracemalloc

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import granalytics as ga  # noqa: E402
from granalytics.datasets.synthetic import write_synthetic_run  # noqa: E402
from granalytics.analysis.particle_tables import particle_frames  # noqa: E402
from granalytics.report.files import stream_table  # noqa: E402


def measure(build):
    """(result, peak traced bytes, wall seconds) of ``build()``."""
    tracemalloc.start()
    t0 = time.perf_counter()
    result = build()
    wall = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return result, peak, wall


def row(label, path, window, tmp):
    with ga.open_run(path) as run:
        frames = run.select(revolutions=window)
        n = run.n_particles
        table, peak, wall = measure(lambda: ga.particle_table(frames))
        size = table.memory_usage(deep=True).sum()
        rows = len(table)
        del table
        out = os.path.join(tmp, "particles.parquet")
        _, peak_stream, wall_stream = measure(lambda: stream_table(particle_frames(frames), out))
        disk = os.path.getsize(out)
    mb = 1e-6
    print(f"| {label} | {n} | {len(frames)} | {rows} | {size * mb:.1f} | {size / rows:.0f} | {peak * mb:.1f} | "
          f"{wall:.1f} | {peak_stream * mb:.1f} | {disk * mb:.1f} | {wall_stream:.1f} |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="*")
    parser.add_argument("--window", default="3:6", help="revolutions R0:R1 (default 3:6)")
    parser.add_argument("--synthetic", type=int, nargs="*", default=[], metavar="N",
                        help="also a physics-free run of N particles (61 frames)")
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    print("| run | particles | frames | rows | table [MB] | bytes per row | peak building it [MB] | s | "
          "peak streamed to Parquet [MB] | Parquet file [MB] | s |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for path in args.runs:
            row(os.path.basename(path), path, window, tmp)
        for n in args.synthetic:
            path = os.path.join(tmp, f"synthetic-{n}.h5")
            write_synthetic_run(path, n_particles=n, revolutions=6.0, frames_per_revolution=20)
            row(f"synthetic, {n} particles", path, window, tmp)


if __name__ == "__main__":
    main()
