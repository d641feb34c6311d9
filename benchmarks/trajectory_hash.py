"""Fingerprint of a simulated trajectory, to show that a speed change left the physics bit for bit.

Usage: python benchmarks/trajectory_hash.py [--threads 1,2] [--steps 12000] [--preset lab-cg2]

Fills and settles the preset's drum (lab-cg2: 375 particles), wets it (films of 1 % V_p, a
spray every 0.01 s instead of the preset's 0.2 s, so that bridges form, rupture and migrate
within the run), advances it ``--steps`` steps at each thread count and prints a SHA-256 (first 8 hex digits) of the particle
state (positions, velocities, angular velocities, films; rows in particle-id order) and of every
live interaction (bodies by id, bridge volume, tangential spring, normal force), with the number
of rebuilds and live bridges beside it. Run it before and after a change, after ``make clean``
(numba's on-disk cache does not notice edits in a function that a cached kernel calls from another
module): an optimisation that keeps the trajectory prints the same hashes, and the hash is the
same at every thread count.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import os
import sys
import time

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from sim.params import preset, preset_original  # noqa: E402
from sim.run import Simulation  # noqa: E402


def trajectory_fingerprint(sim) -> str:
    """SHA-256 (8 hex digits) of the particle state and the live interactions of ``sim``, independent of
    the row order the simulator keeps its particles in."""
    s = sim.state
    n = s.n_particles
    order = np.argsort(s.ids)
    digest = hashlib.sha256()
    for a in (s.pos, s.vel, s.omega, s.film[:n]):
        digest.update(np.ascontiguousarray(a[order]).tobytes())
    digest.update(np.ascontiguousarray(s.film[n:]).tobytes())
    body_id = np.concatenate([s.ids, -1 - np.arange(sim.n_walls)])
    live = np.flatnonzero(s.alive)
    keys = np.column_stack([body_id[s.pair_i[live]], body_id[s.pair_j[live]]])
    by_key = np.lexsort((keys[:, 1], keys[:, 0]))
    live = live[by_key]
    digest.update(np.ascontiguousarray(keys[by_key]).tobytes())
    for a in (s.v_b, s.fs, s.f_normal):
        digest.update(np.ascontiguousarray(a[live]).tobytes())
    return digest.hexdigest()[:8]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--steps", type=int, default=12000)
    parser.add_argument("--preset", default="lab-cg2")
    args = parser.parse_args()
    original, _ = preset_original(args.preset)
    print(f"{args.preset}, {args.steps} steps after settling; numba {numba.__version__}")
    for threads in (int(t) for t in args.threads.split(",")):
        t0 = time.perf_counter()
        params = dataclasses.replace(preset(args.preset), initial_film=0.01, spray_interval=0.01)
        sim = Simulation(params, original)
        numba.set_num_threads(threads)
        sim.advance(args.steps)
        s = sim.state
        n = s.n_particles
        bridges = int((s.alive[n * sim.n_walls:] & (s.v_b[n * sim.n_walls:] > 0)).sum())
        print(f"threads {threads}: hash {trajectory_fingerprint(sim)}  ({n} particles, {bridges} live bridges, "
              f"{s.n_sprays} sprays, {time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
