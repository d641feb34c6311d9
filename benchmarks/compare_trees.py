"""Two versions of the simulator on the same saved bed, runs alternating: is a change faster?

Usage: python benchmarks/compare_trees.py OLD_TREE NEW_TREE --bed CHECKPOINT [--steps N]
       [--threads 1,2] [--rounds 3]

OLD_TREE and NEW_TREE are source trees of this repository (e.g. ``git worktree add /tmp/base
HEAD`` for the committed code and ``.`` for the working tree). Each measurement runs in a fresh
process with ``PYTHONPATH`` pointing at one tree: it restores the checkpoint (a settled bed, e.g.
``build/beds/drum-20000.npz`` written by ``profile_step.py --beds build/beds``), advances 50
steps to load the kernels and warm the caches, then times ``--steps`` steps. The trees alternate
within every round, so both see the same drift of this shared machine; the table gives the
best of the rounds per tree and thread count and the ratio new/old. Kernels are compiled by the
first run of each tree (numba caches them beside the sources), outside the timing.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

# the child times as sim_throughput.rate() does, written out: importing sim_throughput would put
# this tree in front of the measured tree's PYTHONPATH (it inserts its own root into sys.path)
CHILD = """
import json, sys, time
import numba
try:
    from sim.checkpoint import read_checkpoint
except ImportError:  # a tree from before sim/checkpoint.py: the same file format, read by Simulation
    from sim.run import Simulation
    read_checkpoint = Simulation.from_checkpoint
sim = read_checkpoint(sys.argv[1])[0]
numba.set_num_threads(int(sys.argv[3]))
sim.advance(50)
t0 = time.perf_counter()
sim.advance(int(sys.argv[2]))
wall = time.perf_counter() - t0
print(json.dumps({"rate": int(sys.argv[2]) * sim.state.n_particles / wall}))
"""


def measure(tree, bed, steps, threads):
    """Particle-steps per second of ``steps`` steps from ``bed`` with the simulator of ``tree``."""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree))
    out = subprocess.run([sys.executable, "-c", CHILD, os.path.abspath(bed), str(steps), str(threads)],
                         env=env, cwd=os.path.abspath(tree), capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{tree}: the measurement failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])["rate"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old_tree")
    parser.add_argument("new_tree")
    parser.add_argument("--bed", required=True, help="checkpoint of a settled bed")
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    threads = [int(t) for t in args.threads.split(",")]
    for tree in (args.old_tree, args.new_tree):
        measure(tree, args.bed, 10, 1)  # compile (or load) the kernels of each tree
    best = {}
    for r in range(args.rounds):
        for thr in threads:
            for tree in (args.old_tree, args.new_tree):
                rate = measure(tree, args.bed, args.steps, thr)
                best[tree, thr] = max(best.get((tree, thr), 0.0), rate)
                print(f"round {r + 1}, {thr} thread(s), {tree}: {rate / 1e6:.2f} M particle-steps/s", flush=True)
    print(f"\n{args.bed}, {args.steps} steps, best of {args.rounds} alternating rounds [M particle-steps/s]")
    print(f"{'threads':>8}{'old':>10}{'new':>10}{'new/old':>10}")
    for thr in threads:
        old, new = best[args.old_tree, thr], best[args.new_tree, thr]
        print(f"{thr:>8}{old / 1e6:>10.2f}{new / 1e6:>10.2f}{new / old:>10.3f}")
    if len(threads) > 1:
        for tree, name in ((args.old_tree, "old"), (args.new_tree, "new")):
            print(f"{name}: {threads[-1]} threads / {threads[0]}: {best[tree, threads[-1]] / best[tree, threads[0]]:.2f}x")


if __name__ == "__main__":
    main()
