"""A few thousand steps of the paper's CG1 system (120 000 particles) and its projected wall time.

Usage: python benchmarks/paper_cg1_steps.py [--steps 2000] [--threads 1,2] [--collapse 30000] [--relax 4000]

The ``paper-cg1`` preset fills the drum on a lattice and settles it for 0.3 s (100 000 steps,
about 1.5 hours here) before the drum turns. To measure in minutes instead, the lattice (with
the preset's initial films on) collapses under 10 g for ``--collapse`` steps and
relaxes for ``--relax`` steps (4 000) at 1 g in the static drum; the drum then turns, with spraying, for 500
steps before the timed segments. The bed is compacted but younger than a real run's, so the
rate is that of a bed with the contacts and bridges printed beside it. The top of the lattice
falls about 50 mm: at 10 g that takes ~11 000 steps, and the bed must come to rest before
gravity drops back to 1 g (with 14 000 steps it had not: 0.18 contacts per particle, a bed
still bouncing).

For each thread count it prints particle-steps/s over ``--steps`` steps (through
``Simulation.advance``: rebuilds and the Python between kernel calls included), the share of the
time spent in rebuilds and how often they happen, and the projected wall time of the paper's
6 revolutions (6.3 M steps at Δt = 3 µs, Ω = 2 rad/s) at that rate.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numba

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from _bench import live_counts, run_segment, settle_and_turn  # noqa: E402

from sim.params import preset  # noqa: E402
from sim.run import Simulation  # noqa: E402


def compacted_paper_cg1(collapse_steps, relax_steps):
    """The paper-cg1 bed: lattice filled (one settling step), collapsed under 10 g, relaxed at 1 g,
    then turned 500 steps."""
    p = preset("paper-cg1")
    sim = Simulation(dataclasses.replace(p, settle_time=p.dt))  # fill, one settling step, films on
    sim.params = p
    settle_and_turn(sim, collapse_steps, relax_steps)
    return sim


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000, help="timed steps per thread count (default 2000)")
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--collapse", type=int, default=30000, help="settling steps at 10 g (default 30000)")
    parser.add_argument("--relax", type=int, default=4000, help="then settling steps at 1 g (default 4000)")
    args = parser.parse_args()
    t0 = time.perf_counter()
    sim = compacted_paper_cg1(args.collapse, args.relax)
    p, n = sim.params, sim.state.n_particles
    ips, bps = live_counts(sim)
    print(f"paper-cg1: {n} particles, Δt = {p.dt:g} s; {args.collapse} steps at 10 g + {args.relax} at 1 g + 500 turning, "
          f"set up in {time.perf_counter() - t0:.0f} s; {ips:.2f} interactions and {bps:.2f} bridges per particle")
    total_steps = 6 * p.revolution_period / p.dt
    print(f"{'threads':>8}{'steps':>7}{'M p-steps/s':>13}{'rebuild share':>15}{'rebuild every':>15}{'6 revolutions [h]':>19}")
    for thr in (int(x) for x in args.threads.split(",")):
        numba.set_num_threads(thr)
        wall, spent = run_segment(sim, args.steps)
        rate = n * args.steps / wall
        every = args.steps / max(spent["rebuilds"], 1)
        print(f"{thr:>8}{args.steps:>7}{rate / 1e6:>13.2f}{spent['rebuild'] / wall:>15.1%}{every:>15.0f}"
              f"{n * total_steps / rate / 3600:>19.1f}", flush=True)


if __name__ == "__main__":
    main()
