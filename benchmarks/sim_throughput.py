"""Simulator throughput: particle-steps per second, compile time, CG speed-up, and YADE.

Usage: python benchmarks/sim_throughput.py [--quick] [--no-yade]

1. Compile time of the kernels (fresh numba cache, in a child process) and cache-load time.
2. The lab drum with 5 000 wet particles (films of 0.5 % V_p, Table 1 physics, migration on),
   settled 0.1 s: particle-steps/s at 1 and 2 threads, live contacts and bridges per particle.
3. CG speed-up at equal physics: lab-cg1/2/3 settled, then simulated seconds per wall second.
4. If ``yade`` is on the PATH: the drum of ``benchmarks/yade_drum_throughput.py`` (R_D = 0.04 m,
   L = 0.012 m, the same lattice filling and radii) in YADE and here, same Δt, 1 and 2 threads;
   YADE both with OpenMP's default spinning and with the short spin granalytics sets for itself
   (GOMP_SPINCOUNT=3000), the ratio taken against YADE's best.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import random
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

from sim.params import SimParams, _ORIGINALS, cg_scale  # noqa: E402
from sim.run import Simulation  # noqa: E402


def live_counts(sim):
    s = sim.state
    n = s.n_particles
    pairs = s.alive[n * sim.n_walls:]
    wet = pairs & (s.v_b[n * sim.n_walls:] > 0)
    walls = s.alive[: n * sim.n_walls].sum()
    # interactions per particle counted at both ends (as YADE's 2·n_interactions/n), walls once
    return (2 * pairs.sum() + walls) / n, 2 * wet.sum() / n


def rate(sim, steps, threads):
    numba.set_num_threads(threads)
    sim.advance(50)
    t0 = time.perf_counter()
    sim.advance(steps)
    wall = time.perf_counter() - t0
    return steps * sim.state.n_particles / wall, wall


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


def yade_lattice(rd, length):
    """The particle set of benchmarks/yade_drum_throughput.py (same loop, same random stream)."""
    random.seed(1)
    a = 1.85e-3
    pos, rad = [], []
    x = -rd + a
    while x < rd - a:
        y = -rd + a
        while y < -0.2 * rd:
            z = a
            while z < length - a:
                if math.hypot(x, y) < rd - 1.2 * a:
                    pos.append((x, y, z))
                    rad.append(0.75e-3 * random.uniform(0.8, 1.2))
                z += a
            y += a
        x += a
    return np.array(pos), np.array(rad)


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
    args = parser.parse_args()
    q = 0.3 if args.quick else 1.0
    cores = numba.config.NUMBA_NUM_THREADS
    print(f"numba {numba.__version__}, threading layer priority {numba.config.THREADING_LAYER_PRIORITY}, {cores} cores")

    ct = compile_time()
    print(f"\n1. kernels: compile {ct['compile']:.1f} s, load from cache {ct['cache load']:.1f} s")

    lab = dataclasses.replace(_ORIGINALS["lab"], n_particles=5000, initial_film=0.005, settle_time=0.1 * q)
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

    if args.no_yade or shutil.which("yade") is None:
        print("\n4. yade not on the PATH: skipped (apt-get install yade)")
        return
    rd, length = 0.04, 0.012
    settle, measure = int(40000 * q), int(3000 * q)
    pos, rad = yade_lattice(rd, length)
    p = SimParams(n_particles=len(pos), drum_radius=rd, drum_length=length, spray_radius=0.0,
                  initial_film=0.03, viscous=False)
    ours = Simulation.from_particles(p, pos, rad, film=p.initial_film * 4 / 3 * np.pi * rad**3)
    ours._advance(settle, settling=True)
    ours.advance(500)
    print(f"\n4. YADE drum (R_D = {rd} m, L = {length} m, {len(pos)} particles, Δt = {p.dt:g} s, "
          f"{settle} settling + {measure} measured steps)")
    print(f"{'threads':>8}{'ours ps/s':>12}{'YADE ps/s':>12}{'YADE spin3000':>15}{'ours int/p':>12}{'YADE int/p':>12}")
    ours_best, yade_best = 0.0, 0.0
    for threads in sorted({1, cores}):
        r, _ = rate(ours, measure, threads)
        y = run_yade(threads, rd, length, settle, measure, None)
        y_spin = run_yade(threads, rd, length, settle, measure, 3000)
        ours_best = max(ours_best, r)
        yade_best = max(yade_best, y["particle_steps_per_s"], y_spin["particle_steps_per_s"])
        print(f"{threads:>8}{r:>12.3e}{y['particle_steps_per_s']:>12.3e}{y_spin['particle_steps_per_s']:>15.3e}"
              f"{live_counts(ours)[0]:>12.2f}{y['interactions_per_particle']:>12.2f}")
    print(f"ours (best) / YADE (best thread count and OpenMP spin setting) = {ours_best / yade_best:.2f}")


if __name__ == "__main__":
    main()
