"""Threshold sensitivity: one-pass C_agg sweep against independent identifications.

Usage: python benchmarks/sensitivity.py [--particles 120000] [--c-values 100]

On the synthetic paper-scale frame (granalytics.datasets.synthetic, 120 000 particles, ~300 000 contacts):
the one-pass sweep over 100 C_agg × 5 A_agg values, against 500 independent GNA
identifications (fast backend) plus their frame statistics, in the same run. Both give the
same statistics (checked here and in tests/test_sensitivity.py).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import granalytics as ga  # noqa: E402
from granalytics.datasets.synthetic import synthetic_snapshot  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, default=120_000)
    parser.add_argument("--c-values", type=int, default=100)
    args = parser.parse_args()
    frame = synthetic_snapshot(args.particles, seed=1)
    c_grid = np.linspace(0.01, 1.0, args.c_values)
    a_grid = [5.0, 10.0, 20.0, 45.0, 90.0]
    ga.sensitivity([synthetic_snapshot(200, seed=0)], c_grid, a_grid)  # compile / load kernels
    ga.identify(synthetic_snapshot(200, seed=0))

    sweeps = []
    for _ in range(5):
        t0 = time.perf_counter()
        table = ga.sensitivity([frame], c_grid, a_grid)
        sweeps.append(time.perf_counter() - t0)
    t0 = time.perf_counter()
    rows = []
    for a in a_grid:
        for c in c_grid:
            rows.append(ga.frame_stats(frame, ga.identify(frame, c_agg=c, a_agg_deg=a)).iloc[0])
    independent = time.perf_counter() - t0
    same = all(
        table[(table.a_agg_deg == a) & (table.c_agg == c)].yield_fraction.iloc[0] == r.yield_fraction
        for (a, c), r in zip(((a, c) for a in a_grid for c in c_grid), rows)
    )
    n = len(c_grid) * len(a_grid)
    print(f"sensitivity grid {len(c_grid)} C_agg × {len(a_grid)} A_agg on {frame.n_particles} particles, "
          f"{frame.n_contacts} contacts")
    print(f"{'method':<34}{'seconds':>10}{'ratio':>8}")
    print(f"{'one-pass sweep (median of 5)':<34}{np.median(sweeps):>10.3f}{1.0:>8.1f}")
    print(f"{f'{n} independent identifications':<34}{independent:>10.3f}{independent / np.median(sweeps):>8.1f}")
    print("identical yields:", "yes" if same else "NO")
    if not same:
        sys.exit(1)


if __name__ == "__main__":
    main()
