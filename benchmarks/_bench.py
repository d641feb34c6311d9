"""What the benchmark scripts share (private to benchmarks/): the 3-D drum lattice that ours,
LIGGGHTS and YADE all fill, settled drums of several sizes (saved and restored), live-interaction
counts, timed segments and the particle-step rate. Importing it puts the repository root on
``sys.path`` (the scripts run as ``python benchmarks/NAME.py``)."""

from __future__ import annotations

import dataclasses
import math
import os
import random
import sys
import time

import numba
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from sim.params import SimParams  # noqa: E402
from sim import _kernels  # noqa: E402
from sim import run as sim_run  # noqa: E402
from sim.checkpoint import read_checkpoint, write_checkpoint  # noqa: E402
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


def drum_lattice(rd, length):
    """The particle set of benchmarks/yade_drum_throughput.py and liggghts_drum/make_drum.py (same loop,
    same random stream): positions (N, 3) [m] and radii (N,) [m]."""
    # A 3-D lattice (the same sites, radii and offsets as benchmarks/sim_throughput.py::drum_lattice
    # and liggghts_drum/make_drum.py): rows of spacing a, every other row (along y, against gravity)
    # shifted by a/2 in x and z so that it nests into the row below as the bed settles, and every
    # sphere moved by a random offset in x, y and z within the ball of radius a/2 - r around its site.
    random.seed(1)
    a = 1.85e-3
    atoms = []
    y = -rd + a
    row = 0
    while y < -0.2 * rd:
        shift = 0.5 * a * (row % 2)
        x = -rd + a + shift
        while x < rd - a:
            z = a + shift
            while z < length - a:
                if math.hypot(x, y) < rd - 1.2 * a:
                    r = 0.75e-3 * random.uniform(0.8, 1.2)
                    d = [random.gauss(0, 1) for _ in range(3)]
                    s = (0.5 * a - r) * random.random() ** (1 / 3) / math.sqrt(sum(c * c for c in d))
                    atoms.append((x + s * d[0], y + s * d[1], z + s * d[2], r))
                z += a
            x += a
        y += a
        row += 1
    atoms = np.array(atoms)
    return atoms[:, :3], atoms[:, 3]


#: particle count -> (drum radius [m], drum length [m], settling steps at 10 g)
SIZES = {2435: (0.04, 0.012, 0), 20000: (0.07, 0.028, 10000), 120000: (0.12, 0.05, 14000)}


SETTLE_1G = 40000  # then this many settling steps at 1 g for the smallest drum, 4000 for the others


def drum_system(size, beds=None):
    """The lattice drum of ``size`` particles, settled and turned for 500 steps. The large beds
    first collapse under 10 g (a 50-layer lattice takes ~60 ms of free fall to close its gaps at
    1 g), then relax at 1 g; the smallest settles at 1 g as in the YADE comparison.

    With ``beds`` (a folder), the settled bed is saved there as a checkpoint the first time and
    restored afterwards (minutes saved per size; delete the folder after a physics change).
    """
    saved = os.path.join(beds, f"drum-{size}.npz") if beds else None
    if saved and os.path.exists(saved):
        return read_checkpoint(saved)[0], f"(restored from {saved})"
    sim, how = _settled_drum(size)
    if saved:
        os.makedirs(beds, exist_ok=True)
        write_checkpoint(sim, saved)
    return sim, how


def _settled_drum(size):
    rd, length, settle_10g = SIZES[size]
    pos, rad = drum_lattice(rd, length)
    p = SimParams(n_particles=len(pos), drum_radius=rd, drum_length=length, spray_radius=0.0,
                  initial_film=0.03, viscous=False)
    sim = Simulation.from_particles(p, pos, rad, film=p.initial_film * 4 / 3 * np.pi * rad**3)
    settle_and_turn(sim, settle_10g, 4000 if settle_10g else SETTLE_1G)
    return sim, (f"{settle_10g} steps at 10 g + 4000 at 1 g" if settle_10g else f"{SETTLE_1G} steps")


def settle_and_turn(sim, steps_10g, steps_1g):
    """Settle ``sim`` in the static drum, ``steps_10g`` steps under 10 g (to collapse a tall
    lattice in minutes) then ``steps_1g`` at 1 g, then turn it for 500 steps."""
    p = sim.params
    if steps_10g:
        sim.params = dataclasses.replace(p, gravity=tuple(10.0 * g for g in p.gravity))
        sim._advance(steps_10g, settling=True)
        sim.params = p
    sim._advance(steps_1g, settling=True)
    sim.advance(500)


def run_segment(sim, steps):
    """Wall time of ``steps`` steps through Simulation.advance, split into kernel calls, rebuilds
    and the Python around them."""
    spent = {"kernel": 0.0, "rebuild": 0.0, "rebuilds": 0}
    kernel, rebuild = _kernels.advance, sim_run.rebuild

    def timed_kernel(*args):
        t0 = time.perf_counter()
        r = kernel(*args)
        spent["kernel"] += time.perf_counter() - t0
        return r

    def timed_rebuild(*args):
        t0 = time.perf_counter()
        r = rebuild(*args)
        spent["rebuild"] += time.perf_counter() - t0
        spent["rebuilds"] += 1
        return r

    _kernels.advance, sim_run.rebuild = timed_kernel, timed_rebuild
    try:
        t0 = time.perf_counter()
        sim.advance(steps)
        total = time.perf_counter() - t0
    finally:
        _kernels.advance, sim_run.rebuild = kernel, rebuild
    return total, spent
