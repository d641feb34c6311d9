"""The simulator on an idle machine and beside a CPU-bound program: does the default thread count hold up?

Usage: python benchmarks/sim_under_load.py [--systems lab-cg3,drum-2435] [--beds build/beds]
       [--modes 1,2,auto] [--seconds 6] [--rounds 3] [--hogs 1]

Each system is settled once (the preset's own filling and settling for a preset name; a saved
benchmark bed ``BEDS/drum-N.npz`` of ``profile_step.py --beds`` for ``drum-N``) and saved as a
checkpoint in a temporary folder. Each measurement is a fresh process that restores it, runs
50 steps on one thread (loading the kernels), then simulates for ``--seconds`` of wall time
with the thread mode under test and prints the rate in particle-steps per second:

- ``1``, ``2``: a fixed count (``--threads 1`` / ``--threads 2``);
- ``auto``: the default of ``python -m sim run`` (:class:`sim.threads.ThreadGovernor`; its
  probes are inside the timed part, as in a real run);
- ``2p``: two threads with OpenMP's passive wait (``GOMP_SPINCOUNT=0``: a thread waiting at a
  barrier sleeps at once instead of spinning first), to compare wait policies.

The machine is *idle* (as far as this script is concerned: other users' load shows in the load
average printed with each table) or *busy*: ``--hogs`` CPU-bound processes (a Python busy loop
each, started and stopped by this script, each ending by itself after 15 minutes at the latest)
run beside the measurement. Rounds alternate the modes and both states, and each table gives
the best of the rounds with the ratios the issue asks for: the default against the best fixed
count when idle, and against one thread when busy; then the default against the one thread of
the same round, round by round, with their median (the rounds' background load differs, and a
best-of-rounds ratio compares the default's best round with the one thread's luckiest).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CHILD = """
import json, sys, time
import numba
from sim.checkpoint import read_checkpoint
sim = read_checkpoint(sys.argv[1])[0]
sim.threads = 1
sim.advance(50)
mode, seconds = sys.argv[2], float(sys.argv[3])
sim.threads = "auto" if mode == "auto" else int(mode.rstrip("p"))
n, steps, chunk = sim.state.n_particles, 0, 20
t0 = time.perf_counter()
while time.perf_counter() - t0 < seconds:
    t1 = time.perf_counter()
    sim.advance(chunk)
    steps += chunk
    chunk = max(1, min(4 * chunk, int(chunk * 0.1 / max(time.perf_counter() - t1, 1e-6))))
wall = time.perf_counter() - t0
gov = sim._governor
print(json.dumps({"rate": steps * n / wall, "n": n,
                  "threads": sorted({t for t, _ in gov.history}) if gov else [numba.get_num_threads()]}))
"""

HOG = "import time\nend = time.time() + 900\nwhile time.time() < end:\n    pass\n"


def prepare(system, beds, folder):
    """Checkpoint of ``system`` (a preset name, or ``drum-N`` from ``beds``) in ``folder``."""
    path = os.path.join(folder, f"{system}.npz")
    if system.startswith("drum-"):
        src = os.path.join(beds, f"{system}.npz")
        if not os.path.exists(src):
            sys.exit(f"{src}: no saved bed (python benchmarks/profile_step.py --beds {beds} makes it)")
        return src
    code = ("import sys; from sim.params import preset, preset_original; from sim.run import Simulation; "
            "from sim.checkpoint import write_checkpoint; "
            f"s = Simulation(preset({system!r}), preset_original({system!r})[0]); s.advance(200); "
            "write_checkpoint(s, sys.argv[1])")
    subprocess.run([sys.executable, "-c", code, path], cwd=ROOT, check=True, env=dict(os.environ, PYTHONPATH=ROOT))
    return path


def measure(ckpt, mode, seconds):
    env = dict(os.environ, PYTHONPATH=ROOT)
    if mode.endswith("p"):
        env["GOMP_SPINCOUNT"] = "0"
    out = subprocess.run([sys.executable, "-c", CHILD, ckpt, mode, str(seconds)], cwd=ROOT, env=env,
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"measurement {mode} failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def start_hogs(k):
    return [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(k)]


def stop_hogs(hogs):
    for h in hogs:
        h.terminate()
    for h in hogs:
        h.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--systems", default="lab-cg3,drum-2435")
    parser.add_argument("--beds", default=os.path.join(ROOT, "build", "beds"))
    parser.add_argument("--modes", default="1,2,auto")
    parser.add_argument("--seconds", type=float, default=6.0, help="wall time of one measurement [s]")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--hogs", type=int, default=1, help="CPU-bound processes of the busy state")
    args = parser.parse_args()
    modes = args.modes.split(",")
    print(f"{os.cpu_count()} cores, affinity {len(os.sched_getaffinity(0))}; {args.rounds} rounds of "
          f"{args.seconds:g} s per measurement, modes {modes}, busy = {args.hogs} CPU-bound process(es)", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        for system in args.systems.split(","):
            ckpt = prepare(system, args.beds, folder)
            measure(ckpt, "1", 0.5)  # compile or load the kernels outside the rounds
            best, used, loads, per_round = {}, {}, {"idle": [], "busy": []}, {}
            for r in range(args.rounds):
                for state in ("idle", "busy"):
                    hogs = start_hogs(args.hogs) if state == "busy" else []
                    try:
                        if hogs:
                            time.sleep(1.0)  # let the hogs get going
                        loads[state].append(os.getloadavg()[0])
                        for mode in modes:
                            res = measure(ckpt, mode, args.seconds)
                            best[state, mode] = max(best.get((state, mode), 0.0), res["rate"])
                            per_round.setdefault((state, mode), []).append(res["rate"])
                            used.setdefault((state, mode), set()).update(res["threads"])
                            print(f"  {system} round {r + 1} {state:>4} {mode:>4}: {res['rate'] / 1e6:.3f} M "
                                  f"particle-steps/s (threads used {res['threads']})", flush=True)
                    finally:
                        stop_hogs(hogs)
            n = res["n"]
            print(f"\n{system} ({n} particles), best of {args.rounds} [M particle-steps/s]; load average (1 min) "
                  f"at the rounds' starts: idle {', '.join(f'{x:.2f}' for x in loads['idle'])}, busy "
                  f"{', '.join(f'{x:.2f}' for x in loads['busy'])}")
            print("| state | " + " | ".join(f"{m} thread(s)" if m != "auto" else "default (auto)" for m in modes)
                  + " | default / best fixed | default / 1 thread |")
            print("| --- " * (len(modes) + 3) + "|")
            for state in ("idle", "busy"):
                fixed = [best[state, m] for m in modes if m != "auto"]
                auto = best.get((state, "auto"), float("nan"))
                print(f"| {state} | " + " | ".join(f"{best[state, m] / 1e6:.3f}" for m in modes)
                      + f" | {auto / max(fixed):.2f} | {auto / best[state, '1']:.2f} |")
            if "auto" in modes and "1" in modes:  # the same round's one thread: both saw the same background load
                for state in ("idle", "busy"):
                    ratios = sorted(a / o for a, o in zip(per_round[state, "auto"], per_round[state, "1"]))
                    print(f"default / 1 thread of the same round, {state}: "
                          f"{', '.join(f'{x:.2f}' for x in ratios)} (median {ratios[len(ratios) // 2]:.2f})")
            print(f"threads the default used: idle {sorted(used.get(('idle', 'auto'), []))}, busy "
                  f"{sorted(used.get(('busy', 'auto'), []))}\n", flush=True)


if __name__ == "__main__":
    main()
