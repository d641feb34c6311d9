"""CG speed-up at equal drum time, from checkpoints of real (wet, sprayed) runs.

Usage: python benchmarks/cg_speedup.py CKPT_CG1 CKPT_CG2 CKPT_CG3 [--sim-time 0.03] [--repeats 2] [--threads 1]

Each checkpoint (``RUN.h5.ckpt.npz`` of ``python -m sim run``) is restored and advanced by the same
simulated time; the table gives the wall time per simulated second (best of the repeats, the runs
alternating) and the speed-up over the first checkpoint, beside the ideal ratio of
particle-steps (N·Δt⁻¹) and the paper's 12× (CG2) and 32× (CG3), and the rate in particle-steps per
second with its ratio to the first's (the speed-up per particle-step: cache, contacts per particle).
Unlike the wall time recorded in
a run's metadata, this is measured with the runs one after the other on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import time

import numba

from sim.checkpoint import read_checkpoint

PAPER = {1.0: 1.0, 2.0: 12.0, 3.0: 32.0}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoints", nargs="+")
    parser.add_argument("--sim-time", type=float, default=0.03, help="simulated seconds per measurement")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    sims = [read_checkpoint(path)[0] for path in args.checkpoints]
    numba.set_num_threads(args.threads)  # after the simulator has configured numba's threading layer
    for sim in sims:  # load the compiled kernels before timing
        sim.advance(10)
    best = [float("inf")] * len(sims)
    for _ in range(args.repeats):
        for k, sim in enumerate(sims):
            steps = int(round(args.sim_time / sim.params.dt))
            t0 = time.perf_counter()
            sim.advance(steps)
            best[k] = min(best[k], (time.perf_counter() - t0) / (steps * sim.params.dt))
    ref = sims[0]
    print("| CG α | particles | Δt [s] | wall s per simulated s | speed-up | ideal N/Δt ratio | paper | "
          "M particle-steps/s | per particle-step |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for sim, wall in zip(sims, best):
        p = sim.params
        ideal = (ref.params.n_particles / ref.params.dt) / (p.n_particles / p.dt)
        rate = p.n_particles / p.dt / wall  # particle-steps per wall second
        # the speed-up over the first beyond fewer particles and longer steps: the cost of one particle-step
        print(f"| {p.alpha:g} | {p.n_particles} | {p.dt:.1e} | {wall:.1f} | {best[0] / wall:.1f}× | {ideal:.0f}× | "
              f"{PAPER.get(p.alpha, float('nan')):g}× | {rate / 1e6:.2f} | {best[0] / wall / ideal:.2f}× |")


if __name__ == "__main__":
    main()
