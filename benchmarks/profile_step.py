"""Where a simulator time step goes: per-component cost at several system sizes.

Usage: python benchmarks/profile_step.py [--sizes 2435,20000,120000] [--threads 1,2] [--steps N] [--beds DIR]
       python benchmarks/profile_step.py --checkpoint CKPT [CKPT ...] [--threads 1,2] [--steps N]

The system is the wet drum of ``benchmarks/yade_drum_throughput.py`` (a 3-D lattice of spacing
1.85 mm in the lower part of the drum, every other row nested into the one below, random offsets, radii 0.75 mm ± 20 %, films of 3 % V_p, Table 1 physics,
no viscous force, Δt = 3e-6 s, 2 rad/s), scaled in drum radius and length to the requested
particle count, settled in a static drum, then turned for 500 steps. For each size and thread
count it prints, in ns per particle-step:

- ``wall slots`` and ``pair slots``: the force pass over the N·W particle–wall slots and over the
  Verlet pair slots (``_kernels._slot_forces`` called alone on each range);
- ``migration``: the liquid-migration pass (sequential, over the blocks in which the force passes
  counted events);
- ``gather+integrate``: force/torque gathering per particle and the leapfrog update;
- ``in-kernel rest``: the step kernel's time not explained by the four (parallel-region starts,
  whose cost is printed first, spray, the skin check);
- ``rebuild`` and ``python``: Verlet-list rebuilds and the Python between kernel calls, per step
  of a real run segment;
- ``output``: one snapshot written to an HDF5 run file, amortised over the 0.05-revolution
  frame interval.

The 20 000 and 120 000-particle beds collapse under 10 g before relaxing at 1 g (printed), so
that they settle in minutes; contacts and bridges per particle are printed beside the costs.
``--checkpoint`` profiles the states of real runs instead (their own drum, liquid and step), e.g.
the paper's CG1 as kept in ``benchmarks/paper_cg1_run/``.
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import sys
import tempfile
import time

import numba
import numpy as np
from numba import njit

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from _bench import SIZES, drum_system, live_counts, run_segment  # noqa: E402

from granalytics import RunWriter
from sim.checkpoint import read_checkpoint
from sim.threads import configure_threading
from sim import _kernels
from sim.drum import baffle_directions
from sim.liquid import migrate_events


@njit
def _repeat_slot_forces(reps, block_lo, block_hi, baffle_dir, omega_drum, block_events, kernel_params, arrays):
    for _ in range(reps):
        _kernels._slot_forces(block_lo, block_hi, baffle_dir, omega_drum, block_events, kernel_params, arrays)


@njit
def _repeat_migration(reps, film, pair_i, pair_j, v_b, v_max, alive, created, ruptured, body_start, body_slots, v_min,
                      body_key, block_events, n_walls):
    n = film.shape[0] - n_walls
    range_lo = np.empty(block_events.shape[0], dtype=np.int64)
    range_hi = np.empty(block_events.shape[0], dtype=np.int64)
    for _ in range(reps):
        m = _kernels.event_ranges(block_events, n, n_walls, pair_i.shape[0], range_lo, range_hi)
        migrate_events(film, pair_i, pair_j, v_b, v_max, alive, created, ruptured, body_start, body_slots, v_min,
                       body_key, range_lo[:m], range_hi[:m])


@njit
def _repeat_gather(reps, kernel_params, arrays):
    for _ in range(reps):
        _kernels._gather_integrate(kernel_params, arrays)


@njit(parallel=True)
def _tiny_region(a):
    for i in numba.prange(a.shape[0]):
        a[i] += 1.0


@njit
def _repeat_tiny_region(reps, a):
    for _ in range(reps):
        _tiny_region(a)


def region_start_cost():
    """Seconds per start of a parallel region with almost no work (one element per thread), at
    the current thread count: the fixed cost each of a step's parallel loops pays."""
    a = np.zeros(numba.get_num_threads())
    return _best(lambda r: _repeat_tiny_region(r, a), 20000)


def _best(fn, reps):
    """Seconds per repetition of ``fn(reps)`` (which loops ``reps`` times in compiled code), best of 3."""
    fn(1)  # compile, warm the caches
    best = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        fn(reps)
        best = min(best, (time.perf_counter() - t0) / reps)
    return best


def component_costs(sim, reps):
    """Seconds per call of each step component on a copy of the current state (the copy is
    mutated: positions drift by a few steps' motion, which changes nothing measurable)."""
    s, p = copy.deepcopy(sim.state), sim.params
    n = s.n_particles
    kernel_params = _kernels.kernel_params(p, sim.n_walls)
    body_key = np.concatenate([s.ids, s.ids.max() + 1 + np.arange(sim.n_walls)])
    arrays = _kernels.kernel_arrays(s, body_key)
    baffle_dir = np.empty((p.n_baffles + 1, 2))
    baffle_directions(p.n_baffles, 0.3, baffle_dir)
    n_wb, n_pb = _kernels.event_blocks(n, sim.n_walls, s.pair_i.shape[0])
    blocks = np.zeros(n_wb + n_pb, dtype=np.int64)
    _kernels.count_block_events(s.created, s.ruptured, n, sim.n_walls, blocks)
    # migration sees the flags and event counts of one real force pass (its events are those of one step)
    _kernels._slot_forces(0, n_wb + n_pb, baffle_dir, p.drum_omega, blocks, kernel_params, arrays)
    flags = s.created.copy(), s.ruptured.copy()
    mig = (s.film.copy(), s.pair_i, s.pair_j, s.v_b.copy(), s.v_max, s.alive.copy(), flags[0], flags[1],
           s.body_start, s.body_slots, p.v_min, body_key, blocks.copy(), sim.n_walls)
    out = {"wall slots": _best(lambda r: _repeat_slot_forces(r, 0, n_wb, baffle_dir, p.drum_omega, blocks, kernel_params, arrays), reps),
           "pair slots": _best(lambda r: _repeat_slot_forces(r, n_wb, n_wb + n_pb, baffle_dir, p.drum_omega, blocks, kernel_params,
                                                             arrays), reps),
           "migration": _best(lambda r: _repeat_migration(r, *mig), reps)}
    out["gather+integrate"] = _best(lambda r: _repeat_gather(r, kernel_params, arrays), reps)
    return out


def output_cost(sim):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "run.h5")
        meta = sim.run_meta()
        with RunWriter(path, meta) as writer:
            writer.append(sim.snapshot(meta))
            spent = 0.0
            for _ in range(3):
                sim.advance(1)
                t0 = time.perf_counter()
                writer.append(sim.snapshot(meta))
                spent += time.perf_counter() - t0
            return spent / 3


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2435,20000,120000")
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--steps", type=int, default=2000, help="steps of the run segment (default 2000)")
    parser.add_argument("--beds", metavar="DIR", help="save the settled beds here, and restore them on later runs")
    parser.add_argument("--checkpoint", nargs="+", metavar="CKPT",
                        help="profile these simulator checkpoints (a real run's wet, sprayed state, e.g. "
                        "benchmarks/paper_cg1_run/paper-cg1.ckpt.npz) instead of the lattice beds (--sizes and --beds are "
                        "then not used)")
    args = parser.parse_args()
    configure_threading()  # before the first parallel kernel, as the simulator does
    sizes = [int(x) for x in args.sizes.split(",")]
    threads = [int(x) for x in args.threads.split(",")]
    print(f"numba {numba.__version__}, {numba.config.NUMBA_NUM_THREADS} cores; ns per particle-step")
    cols = ("wall slots", "pair slots", "migration", "gather+integrate", "in-kernel rest", "rebuild", "python",
            "output", "total")
    print(f"{'N':>7}{'thr':>4}{'int/p':>6}{'br/p':>6}{'rebuild every':>14}" + "".join(f"{c:>17}" for c in cols)
          + f"{'M p-steps/s':>12}")
    for thr in threads:
        numba.set_num_threads(thr)
        print(f"# a parallel region's start costs {region_start_cost() * 1e6:.1f} µs at {thr} thread(s); "
              "a step has four", flush=True)
    for system in args.checkpoint or sizes:
        t0 = time.perf_counter()
        if args.checkpoint:
            sim, info = read_checkpoint(system)
            origin = (f"checkpoint {system} at {sim.time:.3f} s of its run ({info.get('frames', '?')} frames), "
                      f"Δt = {sim.params.dt:.3g} s")
        else:
            sim, settle = drum_system(system, args.beds)
            origin = f"lattice in R_d = {SIZES[system][0]} m, L = {SIZES[system][1]} m, settled: {settle}"
        n = sim.state.n_particles
        ips, bps = live_counts(sim)
        print(f"# N = {n}: {origin}, set up in {time.perf_counter() - t0:.0f} s", flush=True)
        frame_steps = max(1, round(0.05 * sim.params.revolution_period / sim.params.dt))
        for thr in threads:
            numba.set_num_threads(thr)
            steps = max(200, int(args.steps * 2435 / n))
            total, spent = run_segment(sim, steps)
            per_step_kernel = spent["kernel"] / steps
            comp = component_costs(sim, reps=max(3, int(50 * 2435 / n)))
            row = dict(comp)
            row["in-kernel rest"] = per_step_kernel - sum(comp.values())
            row["rebuild"] = spent["rebuild"] / steps
            row["python"] = (total - spent["kernel"] - spent["rebuild"]) / steps
            row["output"] = output_cost(sim) / frame_steps
            row["total"] = total / steps + row["output"]
            every = steps / max(spent["rebuilds"], 1)
            print(f"{n:>7}{thr:>4}{ips:>6.2f}{bps:>6.2f}{every:>14.0f}"
                  + "".join(f"{row[c] / n * 1e9:>17.1f}" for c in cols) + f"{n / row['total'] / 1e6:>12.2f}", flush=True)


if __name__ == "__main__":
    main()
