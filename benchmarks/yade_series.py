"""Our simulator and YADE on the same drum, for several γ and seeds: the runs that
``benchmarks/yade_side_by_side.py`` compares (never needed by the tests).

Usage (from anywhere; the commands run in the repository root)::

    python benchmarks/yade_series.py [--gammas 0.03,0.1095,0.444] [--seeds 0,1,2] [--revolutions 3]
        [--out build/yade] [--keep benchmarks/yade_runs] [--full-window 1:3] [--every 4]

Cases run γ-major: every seed of the first γ, then every seed of the next γ. For each case
TAG = ``g<γ>-s<seed>`` (γ [N/m] of the original system, written with ``%g``), one at a time:

a. our run, ``python -m sim run --preset lab-cg2 --bridge-volume 1e-12 --no-viscous --gamma γ
   --seed S --revolutions R --threads 1 --quiet --out OUT/sim-TAG.h5`` (a frame every 0.05
   revolution);
b. ``python benchmarks/yade_same_drum.py prepare OUT/sim-TAG.h5 OUT/TAG``: the settled bed, the
   physics and the mapping;
c. YADE on that bed, ``yade -n -j 1 -x benchmarks/yade_same_drum.py`` in OUT/TAG (its output in
   OUT/TAG/yade.log, its cost in OUT/TAG/cost.json);
d. ``python benchmarks/yade_same_drum.py convert OUT/TAG OUT/yade-TAG.h5``;
e. ``granalytics subset IN --out KEEP/NAME --float32 --full-window 1:3 --every 4`` of both runs:
   KEEP/sim-TAG.h5 and KEEP/yade-TAG.h5, every frame in the window [1, 3] revolutions and every
   4th before it, stored as float32 (what ``yade_side_by_side.py`` reads).

Each step prints its command and then its cost (wall and CPU time [s] of the command; for YADE
also its steps and steps per second from ``cost.json``).

Resumable: a step is skipped when its output exists and is newer than its input (our run: when it
holds all its frames; an interrupted one is continued with ``--resume``). An interrupted YADE run
starts again from the bed (YADE writes no checkpoint here); its partial ``out/`` is removed first.

Seeds: our simulator's ``--seed`` sets the random filling of the drum. YADE starts from our run's
settled bed (its frame 0) and has no random input of its own, so a case's YADE run belongs to our
seed: the replicas of both codes are the same three beds.

Cost: one case of 3 revolutions of the lab-cg2 drum (375 particles, Δt = 6 µs: 1 570 800 steps)
takes our simulator about 2 minutes on one core (5.4 M particle-steps/s, plus the filling and
settling) and YADE about 10 minutes (2 600–2 800 steps per CPU second, measured over 0.2 revolution
on a 2-core machine with both cores busy): about 2 hours for the 9 cases.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shlex
import shutil
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECIPE = os.path.join(ROOT, "benchmarks", "yade_same_drum.py")


def short(path):
    """``path`` relative to the repository root when it lies inside it (the commands run there)."""
    rel = os.path.relpath(path, ROOT)
    return path if rel.startswith("..") else rel


def fresh(target, *sources):
    """Whether ``target`` exists and is newer than every existing path of ``sources``."""
    if not os.path.exists(target):
        return False
    return all(os.path.getmtime(target) >= os.path.getmtime(s) for s in sources if os.path.exists(s))


def run_step(name, command, cwd=ROOT, log=None):
    """Run ``command`` (a list), printing it and its cost; exit on failure.

    Parameters
    ----------
    name : str
        The step's label in the output.
    command : list of str
        Program and arguments.
    cwd : str
        Working folder (default the repository root).
    log : str, optional
        File that receives the command's stdout and stderr (default: this terminal).

    Returns
    -------
    dict
        ``wall_s`` and ``cpu_s`` [s]: the command's wall-clock time and its CPU time (user +
        system, its children included).
    """
    print(f"[{name}] {'cd ' + shlex.quote(short(cwd)) + ' && ' if cwd != ROOT else ''}"
          f"{shlex.join(command)}" + (f" > {shlex.quote(short(log))} 2>&1" if log else ""), flush=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    if log:
        with open(log, "w") as out:
            done = subprocess.run(command, cwd=cwd, stdout=out, stderr=subprocess.STDOUT)
    else:
        done = subprocess.run(command, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        raise SystemExit(f"[{name}] failed with exit status {done.returncode}" + (f"; see {log}" if log else ""))
    print(f"[{name}] cost: {wall:.1f} s wall, {cpu:.1f} s CPU", flush=True)
    return {"wall_s": wall, "cpu_s": cpu}


def skipped(name, why):
    print(f"[{name}] skipped: {why}", flush=True)


def our_run_state(path, revolutions):
    """``"missing"``, ``"partial"`` (to be resumed) or ``"done"`` for our run ``path``; exits if
    the run holds another number of revolutions than asked for."""
    if not os.path.exists(path):
        return "missing"
    import granalytics as ga

    with ga.open_run(path) as run:
        planned = run.meta.provenance.get("planned_frames")
        frames, last = len(run), float(run.revolutions[-1]) if len(run) else 0.0
    if frames < (planned or 0):
        return "partial"
    if abs(last - revolutions) > 0.01:
        raise SystemExit(f"{path}: a run to {last:g} revolutions, not {revolutions:g}; remove it or ask for "
                         f"--revolutions {last:g}")
    return "done"


def run_case(gamma, seed, args):
    """Steps (a)–(e) of one case (see the module docstring)."""
    tag = f"g{gamma:g}-s{seed}"
    ours, folder = short(os.path.join(args.out, f"sim-{tag}.h5")), short(os.path.join(args.out, tag))
    yade = short(os.path.join(args.out, f"yade-{tag}.h5"))
    setup, cost = os.path.join(folder, "setup.json"), os.path.join(folder, "cost.json")
    print(f"\n== γ = {gamma:g} N/m, seed {seed} ({tag}) ==", flush=True)

    state = our_run_state(ours, args.revolutions)
    if state == "done":
        skipped("sim", f"{ours} holds all its frames")
    else:
        command = [sys.executable, "-m", "sim", "run", "--preset", "lab-cg2", "--bridge-volume", "1e-12",
                   "--no-viscous", "--gamma", f"{gamma!r}", "--seed", str(seed), "--revolutions",
                   f"{args.revolutions!r}", "--threads", "1", "--quiet", "--out", ours]
        run_step("sim", command + (["--resume"] if state == "partial" else []))

    if fresh(setup, ours) and fresh(os.path.join(folder, "meta.toml"), ours):
        skipped("prepare", f"{setup} is newer than {ours}")
    else:
        run_step("prepare", [sys.executable, RECIPE, "prepare", ours, folder])

    if fresh(cost, setup):
        skipped("yade", f"{cost} is newer than {setup}")
    else:
        for stale in (cost, os.path.join(folder, "out")):  # a partial or older YADE run
            if os.path.isdir(stale):
                shutil.rmtree(stale)
            elif os.path.exists(stale):
                os.remove(stale)
        run_step("yade", ["yade", "-n", "-j", "1", "-x", RECIPE], cwd=os.path.join(ROOT, folder),
                 log=os.path.join(ROOT, folder, "yade.log"))
        if not os.path.exists(cost):
            raise SystemExit(f"[yade] no {cost}: the run did not finish; see {folder}/yade.log")
    with open(cost) as f:
        c = json.load(f)
    print(f"[yade] run: {c['steps']} steps in {c['wall_s']:.1f} s wall, {c['cpu_s']:.1f} s CPU "
          f"({c['steps_per_wall_s']:.0f} steps/s wall, {c['steps_per_cpu_s']:.0f} steps/s CPU); "
          f"{c['coplanar_doubles']} of {c['wall_contacts']} wall contacts doubled at the last step", flush=True)

    if fresh(yade, cost):
        skipped("convert", f"{yade} is newer than {cost}")
    else:
        run_step("convert", [sys.executable, RECIPE, "convert", folder, yade, "--overwrite"])

    for code, source in (("sim", ours), ("yade", yade)):
        kept = short(os.path.join(args.keep, os.path.basename(source)))
        if fresh(kept, source):
            skipped(f"subset {code}", f"{kept} is newer than {source}")
            continue
        run_step(f"subset {code}", [sys.executable, "-m", "granalytics", "subset", source, "--out", kept,
                                    "--float32", "--full-window", args.full_window, "--every", str(args.every),
                                    "--overwrite", "--quiet"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gammas", default="0.03,0.1095,0.444",
                        help="surface tensions γ of the original system [N/m], comma-separated "
                             "(default 0.03,0.1095,0.444)")
    parser.add_argument("--seeds", default="0,1,2", help="seeds of our filling, comma-separated (default 0,1,2)")
    parser.add_argument("--revolutions", type=float, default=3.0, help="revolutions of both runs (default 3)")
    parser.add_argument("--out", default="build/yade", help="folder of the full runs (default build/yade)")
    parser.add_argument("--keep", default="benchmarks/yade_runs",
                        help="folder of the float32 subsets (default benchmarks/yade_runs)")
    parser.add_argument("--full-window", default="1:3", help="R0:R1 [revolutions] kept whole (default 1:3)")
    parser.add_argument("--every", type=int, default=4, help="every N-th frame kept outside it (default 4)")
    args = parser.parse_args()
    args.out, args.keep = (os.path.abspath(p) for p in (args.out, args.keep))
    os.chdir(ROOT)  # the commands and the relative paths they print: from the repository root
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.keep, exist_ok=True)
    if shutil.which("yade") is None:
        raise SystemExit("yade is not on PATH (apt-get install yade)")
    gammas = [float(g) for g in args.gammas.split(",")]
    seeds = [int(s) for s in args.seeds.split(",")]
    t0 = time.perf_counter()
    for gamma in gammas:  # γ-major
        for seed in seeds:
            run_case(gamma, seed, args)
    print(f"\nall {len(gammas) * len(seeds)} cases done in {time.perf_counter() - t0:.0f} s; next: "
          f"python benchmarks/yade_side_by_side.py {short(args.keep)} --window {args.full_window}")


if __name__ == "__main__":
    main()
