"""Simulator throughput: particle-steps per second, compile time, CG speed-up, and YADE.

Usage: python benchmarks/sim_throughput.py [--quick] [--no-yade] [--no-liggghts] [--no-scaling]
       [--sections 1,2,3,4,5] [--sizes 2435,20000,120000] [--beds DIR]

1. Compile time of the kernels (fresh numba cache, in a child process) and cache-load time.
2. The lab drum with its 3 000 wet particles (films of 0.5 % V_p, Table 1 physics, migration on),
   settled 0.1 s: particle-steps/s at 1 and 2 threads, live contacts and bridges per particle.
3. CG speed-up at equal physics: lab-cg1/2/3 settled, then simulated seconds per wall second.
4. The wet drum of ``benchmarks/yade_drum_throughput.py`` (2 199 particles, R_D = 0.04 m,
   L = 0.012 m, the same 3-D lattice filling and radii in every code, Δt = 3e-6 s): this simulator
   without the viscous force (as YADE's ViscElCapMat) and with it (as LIGGGHTS' easo law),
   LIGGGHTS 3.8 (``benchmarks/liggghts_drum/run_bench.sh``, MPI processes) if ``liggghts`` is
   on the PATH, YADE if ``yade`` is (both with OpenMP's default spinning and with the short spin
   granalytics sets for itself, GOMP_SPINCOUNT=3000); 1 and 2 threads/processes, runs
   alternating between the codes, best of 3, and the ratios against the targets.
5. Scaling: particle-steps/s of the same drum scaled to 2 435, 20 000 and 120 000 particles
   (``benchmarks/profile_step.py``) at 1 and 2 threads, and the 2-thread speed-up.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

from sim.threads import configure_threading  # noqa: E402
from sim.params import SimParams, _ORIGINALS, cg_scale  # noqa: E402
from sim.run import Simulation  # noqa: E402
from _bench import drum_lattice, live_counts, rate  # noqa: E402


def compile_time():
    code = (
        "import time, dataclasses; t0=time.perf_counter();"
        "from sim.params import SimParams; from sim.run import Simulation;"
        "p=SimParams(n_particles=2, n_baffles=4, drum_radius=0.02, drum_length=0.01);"
        "t1=time.perf_counter(); s=Simulation.from_particles(p, [[0,-0.015,0.005],[0.0016,-0.015,0.005]], [7.5e-4,7.5e-4]);"
        "s.advance(5); t2=time.perf_counter(); s.advance(5); t3=time.perf_counter();"
        "print(t1-t0, t2-t1-(t3-t2))"
    )
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        for label in ("compile", "cache load"):
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True,
                                 cwd=os.path.dirname(HERE))
            out[label] = float(res.stdout.split()[1])
    return out


def run_yade(threads, rd, length, settle, measure, spincount):
    """YADE's RESULT line; ``spincount`` None runs YADE with OpenMP's default spinning, a number
    sets GOMP_SPINCOUNT like granalytics does for its own kernels."""
    env = {k: v for k, v in os.environ.items() if k != "GOMP_SPINCOUNT"}
    if spincount is not None:
        env["GOMP_SPINCOUNT"] = str(spincount)
    res = subprocess.run(["yade", "-n", "-j", str(threads), "-x", os.path.join(HERE, "yade_drum_throughput.py"),
                          str(rd), str(length), str(settle), str(measure)], capture_output=True, text=True, timeout=1800,
                         env=env)
    line = next((l for l in res.stdout.splitlines() if l.startswith("RESULT")), None)
    if line is None:
        raise RuntimeError(f"yade printed no RESULT line: {res.stderr[-500:]}")
    return {k: float(v) for k, v in re.findall(r"(\w+)=([0-9.e+-]+)", line)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter settling and measuring")
    parser.add_argument("--no-yade", action="store_true")
    parser.add_argument("--no-liggghts", action="store_true")
    parser.add_argument("--no-scaling", action="store_true", help="skip section 5 (minutes at 120 000 particles)")
    parser.add_argument("--sections", default="1,2,3,4,5", help="sections to run (default all: 1,2,3,4,5)")
    parser.add_argument("--sizes", default=None, help="particle counts of section 5 (default 2435,20000,120000)")
    parser.add_argument("--beds", metavar="DIR", help="section 5: save the settled beds here, and restore them on later runs")
    args = parser.parse_args()
    sections = {int(x) for x in args.sections.split(",")}
    if args.no_scaling:
        sections.discard(5)
    q = 0.3 if args.quick else 1.0
    cores = numba.config.NUMBA_NUM_THREADS
    configure_threading()  # as the simulator does, before any parallel kernel
    print(f"numba {numba.__version__}, threading layer priority {numba.config.THREADING_LAYER_PRIORITY}, {cores} cores")
    if sections & {1, 2, 3}:
        first_sections(q, cores)
    if 4 in sections:
        comparison(q, cores, with_yade=not args.no_yade and shutil.which("yade") is not None,
                   with_liggghts=not args.no_liggghts and shutil.which("liggghts") is not None)
    if 5 in sections:
        scaling(q, None if args.sizes is None else [int(x) for x in args.sizes.split(",")], args.beds)


def first_sections(q, cores):
    """Sections 1-3: compile time, the lab drum's rate, the CG speed-up."""
    ct = compile_time()
    print(f"\n1. kernels: compile {ct['compile']:.1f} s, load from cache {ct['cache load']:.1f} s")

    lab = dataclasses.replace(_ORIGINALS["lab"], initial_film=0.005, settle_time=0.1 * q)
    t0 = time.perf_counter()
    sim = Simulation(lab)
    settle_wall = time.perf_counter() - t0
    sim.advance(int(0.02 / lab.dt))  # let bridges form
    print(f"\n2. lab drum, {sim.state.n_particles} wet particles (settled {lab.settle_time:g} s in {settle_wall:.0f} s wall)")
    print(f"{'threads':>8}{'particle-steps/s':>18}{'contacts/particle':>19}{'bridges/particle':>18}")
    ips, bps = live_counts(sim)
    for threads in sorted({1, cores}):
        r, _ = rate(sim, int(2000 * q) + 500, threads)
        print(f"{threads:>8}{r:>18.3e}{ips:>19.2f}{bps:>18.2f}")
    numba.set_num_threads(cores)

    print("\n3. CG speed-up at equal physics (lab drum, wet, settled), all cores")
    print(f"{'preset':>8}{'particles':>11}{'dt s':>10}{'sim s / wall s':>16}{'speed-up':>10}")
    base = None
    for alpha in (1, 2, 3):
        original = dataclasses.replace(_ORIGINALS["lab"], initial_film=0.005, settle_time=0.05 * q)
        p = original if alpha == 1 else cg_scale(original, alpha)
        cg = Simulation(p, original)
        steps = int(round(0.01 * q / p.dt))
        _, wall = rate(cg, steps, cores)
        speed = steps * p.dt / wall
        base = base or speed
        print(f"{'lab-cg%d' % alpha:>8}{cg.state.n_particles:>11}{p.dt:>10.1e}{speed:>16.4f}{speed / base:>10.1f}")


def run_liggghts(procs, rd, length, settle, measure):
    """LIGGGHTS' RESULT line from benchmarks/liggghts_drum/run_bench.sh (MPI processes)."""
    res = subprocess.run(["bash", os.path.join(HERE, "liggghts_drum", "run_bench.sh"), str(rd), str(length), str(settle),
                          str(measure), str(procs)], capture_output=True, text=True, timeout=3600)
    line = next((l for l in res.stdout.splitlines() if l.startswith("RESULT")), None)
    if line is None:
        raise RuntimeError(f"run_bench.sh printed no RESULT line: {res.stdout[-300:]} {res.stderr[-300:]}")
    return {k: float(v) for k, v in re.findall(r"(\w+)=([0-9.e+-]+)", line)}


def comparison(q, cores, with_yade, with_liggghts):
    """Section 4: the 2 199-particle drum in every code, alternating runs, best of 3."""
    rd, length = 0.04, 0.012
    settle, measure = int(40000 * q), int(3000 * q)
    pos, rad = drum_lattice(rd, length)
    print(f"\n4. the wet drum of benchmarks/yade_drum_throughput.py (R_D = {rd} m, L = {length} m, {len(pos)} "
          f"particles, Δt = 3e-6 s, {settle} settling + {measure} measured steps), alternating runs, best of 3")
    if not (with_yade or with_liggghts):
        print("   yade and liggghts not on the PATH: only this simulator (apt-get install yade liggghts)")
    ours = {}
    for viscous in (False, True):  # YADE's ViscElCapMat has no viscous force, LIGGGHTS' easo law has
        p = SimParams(n_particles=len(pos), drum_radius=rd, drum_length=length, spray_radius=0.0,
                      initial_film=0.03, viscous=viscous)
        sim = Simulation.from_particles(p, pos, rad, film=p.initial_film * 4 / 3 * np.pi * rad**3)
        sim._advance(settle, settling=True)
        sim.advance(500)
        ours[viscous] = sim
    threads = sorted({1, cores})
    best = {}
    for _ in range(3):
        for t in threads:
            for viscous, sim in ours.items():
                key = ("ours, viscous" if viscous else "ours", t)
                best[key] = max(best.get(key, 0.0), rate(sim, measure, t)[0])
            if with_liggghts:
                r = run_liggghts(t, rd, length, settle, measure)
                best[("LIGGGHTS", t)] = max(best.get(("LIGGGHTS", t), 0.0), r["particle_steps_per_s"])
            if with_yade:
                for spin in (None, 3000):
                    r = run_yade(t, rd, length, settle, measure, spin)
                    best[("YADE", t)] = max(best.get(("YADE", t), 0.0), r["particle_steps_per_s"])
    numba.set_num_threads(cores)
    codes = ["ours", "ours, viscous"] + (["LIGGGHTS"] if with_liggghts else []) + (["YADE"] if with_yade else [])
    print(f"{'code':<16}" + "".join(f"{f'{t} thr/proc':>14}" for t in threads) + f"{'best':>14}")
    for code in codes:
        print(f"{code:<16}" + "".join(f"{best[(code, t)]:>14.3e}" for t in threads)
              + f"{max(best[(code, t)] for t in threads):>14.3e}")

    def top(code):
        return max(best[(code, t)] for t in threads)

    if with_liggghts:
        print(f"ours (viscous, like LIGGGHTS) / LIGGGHTS, 1 thread vs 1 process: "
              f"{best[('ours, viscous', 1)] / best[('LIGGGHTS', 1)]:.2f}   (target >= 1.25)")
        print(f"ours (viscous) best / LIGGGHTS best: {top('ours, viscous') / top('LIGGGHTS'):.2f}   (target >= 2)")
    if with_yade:
        print(f"ours (no viscous, like YADE) best / YADE best (thread count and OpenMP spin setting): "
              f"{top('ours') / top('YADE'):.2f}   (target >= 3)")


def scaling(q, sizes=None, beds=None):
    """Section 5: particle-steps/s against N (the same drum, scaled) at 1 and 2 threads."""
    from _bench import SIZES, drum_system

    print("\n5. scaling: the same wet drum scaled in R_D and L (benchmarks/profile_step.py), best of 3")
    print(f"{'particles':>10}{'int/p':>7}{'br/p':>7}{'1 thread':>12}{'2 threads':>12}{'speed-up':>10}")
    unknown = set(sizes or ()) - set(SIZES)
    if unknown:
        raise SystemExit(f"--sizes: no drum for {sorted(unknown)} particles; available: {', '.join(map(str, SIZES))}")
    for size in sizes or SIZES:
        sim, _ = drum_system(size, beds)
        n = sim.state.n_particles
        steps = max(200, int(2.4e7 * q / n))  # ~10 s per measurement: shorter ones drift by 20-40 % here
        r = {t: 0.0 for t in (1, 2)}
        for _ in range(3):
            for t in (1, 2):
                r[t] = max(r[t], rate(sim, steps, t)[0])
        ips, bps = live_counts(sim)
        print(f"{n:>10}{ips:>7.2f}{bps:>7.2f}{r[1]:>12.3e}{r[2]:>12.3e}{r[2] / r[1]:>10.2f}", flush=True)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)

if __name__ == "__main__":
    main()
