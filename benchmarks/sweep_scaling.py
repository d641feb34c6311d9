"""Wall time of a parameter sweep at 1 and 2 dask workers (and more with --workers).

Usage: python benchmarks/sweep_scaling.py [--workers 1,2] [--revolutions 1] [--points 4]

The sweep is a slice of the bundled gamma-omega study: lab-cg3 (111 particles), γ from the
list below × Ω = 2, 3 rad/s, ``--revolutions`` revolutions each, every frame written. It runs once
per worker count into a fresh temporary folder (nothing is reused between runs), on a local
dask cluster of single-threaded workers, and prints the wall time, the points per minute and the
speed-up over one worker. Each point's simulation is independent, so the ideal speed-up is the
worker count (up to the number of cores); what is lost goes to cluster start-up, process
start-up with the numba cache load, and the tail when fewer points than workers remain.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from sim.sweep import run_sweep  # noqa: E402

GAMMAS = (0.06, 0.1095, 0.2, 0.3, 0.444, 0.03, 0.01)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts (default 1,2)")
    parser.add_argument("--revolutions", type=float, default=1.0)
    parser.add_argument("--points", type=int, default=4, help="an even number of points, 2 to 14 (default 4)")
    args = parser.parse_args()
    if not (2 <= args.points <= 2 * len(GAMMAS) and args.points % 2 == 0):
        parser.error("--points must be an even number from 2 to 14")
    gammas = ", ".join(repr(g) for g in GAMMAS[: args.points // 2])
    spec = (f'preset = "lab-cg3"\nrevolutions = {args.revolutions!r}\nframe_every_rev = 0.05\n'
            f"checkpoint_every = 20\n\n[grid]\ngamma = [{gammas}]\nomega = [2.0, 3.0]\n")
    print(f"sweep of {args.points} lab-cg3 points (γ = {gammas} N/m × Ω = 2, 3 rad/s), "
          f"{args.revolutions:g} revolutions each, {os.cpu_count()} cores")
    print(f"{'workers':>8}{'wall s':>10}{'points/min':>12}{'speed-up':>10}")
    base = None
    for workers in (int(w) for w in args.workers.split(",")):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "spec.toml")
            with open(path, "w") as f:
                f.write(spec)
            t0 = time.perf_counter()
            manifest = run_sweep(path, os.path.join(tmp, "sweep"), workers=workers, progress=False)
            wall = time.perf_counter() - t0
        if not (manifest.status == "done").all():
            raise SystemExit(f"points failed: {manifest[manifest.status != 'done'][['point', 'error']]}")
        base = base or wall
        print(f"{workers:>8}{wall:>10.1f}{60 * args.points / wall:>12.2f}{base / wall:>10.2f}", flush=True)


if __name__ == "__main__":
    main()
