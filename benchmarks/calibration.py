"""Time of a threshold calibration's size distributions: the one-pass sweep (ga.size_class_grid) against
a loop of identifications, one per grid point (identify + size_class_fractions), on the same frames.

    python benchmarks/calibration.py [--run datasets/lab-cg1.h5] [--window 3:6] [--loop-frames 10]

The loop is timed on --loop-frames frames and scaled to the window's frame count (it is linear in
frames); the one pass runs on the whole window. Prints a table.
"""

import argparse
import pathlib
import time

import numpy as np

import granalytics as ga

ROOT = pathlib.Path(__file__).resolve().parents[1]
EDGES = np.r_[0.0, 1e-3 * np.array([1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.2]), np.inf]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", default=str(ROOT / "datasets" / "lab-cg1.h5"))
    parser.add_argument("--window", default="3:6")
    parser.add_argument("--loop-frames", type=int, default=10)
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    c_grid, a_grid = np.linspace(0.2, 0.9, 15), np.linspace(5, 60, 12)
    with ga.open_run(args.run) as run:
        frames = list(run.select(revolutions=window))
    ga.size_class_grid(frames[:1], EDGES, c_grid[:2], a_grid[:2])  # compile (numba cache) outside the timing
    ga.size_class_fractions(frames[0], ga.identify(frames[0]).labels, EDGES)
    rows = []
    for measure in ("volume", "width"):
        t = time.perf_counter()
        grid = ga.size_class_grid(frames, EDGES, c_grid, a_grid, measure=measure)
        one_pass = time.perf_counter() - t
        sample = frames[:: max(1, len(frames) // args.loop_frames)][: args.loop_frames]
        t = time.perf_counter()
        for snapshot in sample:
            for a in a_grid:
                for c in c_grid:
                    ga.size_class_fractions(snapshot, ga.identify(snapshot, c_agg=c, a_agg_deg=a).labels, EDGES, measure)
        loop = (time.perf_counter() - t) * len(frames) / len(sample)
        t = time.perf_counter()
        ga.calibrate_thresholds(grid, ga.read_sieve_csv(ROOT / "datasets" / "sieve" / "example-sieve.csv"), c_grid,
                                a_grid, window=window)
        fit = time.perf_counter() - t
        rows.append((measure, len(frames), one_pass, loop, fit))
    print(f"{pathlib.Path(args.run).name}, revolutions {args.window}, grid 15 x 12 (C_agg 0.2:0.9, A_agg 5:60), "
          f"{len(EDGES) - 1} classes; loop timed on {args.loop_frames} frames and scaled")
    print(f"{'measure':8s} {'frames':>6s} {'one pass [s]':>13s} {'loop [s]':>9s} {'speed-up':>9s} {'fit+bootstrap [s]':>18s}")
    for measure, n, one, loop, fit in rows:
        print(f"{measure:8s} {n:6d} {one:13.2f} {loop:9.1f} {loop / one:9.0f} {fit:18.2f}")


if __name__ == "__main__":
    main()
