"""The time-step study: does the step Δt = factor × the paper's (after the CG rule) change the
statistics? Factors 0.5-2.5 on two systems, many seeds, one window.

Usage::

    python benchmarks/timestep_study.py run [--seeds 0-9] [--factors 0.5,1,1.5,2,2.5] [--jobs 2] [--dir build/timestep]
    python benchmarks/timestep_study.py table [--seeds 0-9] [--window 2:4] [--dir build/timestep]

``run`` makes the missing runs (``python -m sim run ... --dt-factor F``, one thread each, ``--jobs``
at a time; an interrupted run resumes from its checkpoint). ``table`` prints, for each system and
factor, the steady yield, ⟨V_g⟩/V_p, N_g/N, coordination, bed angle and kinetic energy (mean ±
replica s.e. over the seeds, angle co-motion test) and the deviation of each from factor 1 (the
paper's step) in units of the two runs' combined replica standard error, then the largest factor
that stays within two of them on every figure.

The systems:

- ``cg3``: the lab preset ``lab-cg3`` (α = 3, Table 2's rule, 111 particles, D/d 11.2);
- ``cg1``: an α = 1 system of the same drum family and confinement (``lab-cg1 --drum-ratio
  11.2``, 111 particles of 1.5 mm; the CG1 of the CG-rules study).
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import warnings
from concurrent.futures import ThreadPoolExecutor

import granalytics as ga
from granalytics.analysis.confinement import confinement_table

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cg_rules_study import COLUMNS, finished, seeds_of, wall_times  # noqa: E402  (a sibling script)

SYSTEMS = {"cg3": "--preset lab-cg3", "cg1": "--preset lab-cg1 --drum-ratio 11.2"}
FACTORS = "0.5,1,1.5,2,2.5"
REVOLUTIONS = 4


def run_path(system, factor, seed, folder):
    return os.path.join(folder, f"{system}-dt{factor:g}-seed{seed}.h5")


def command(system, factor, seed, folder):
    out = run_path(system, factor, seed, folder)
    resume = ["--resume"] if os.path.exists(f"{out}.ckpt.npz") else ["--overwrite"]
    return ([sys.executable, "-m", "sim", "run", *SYSTEMS[system].split(), "--revolutions", str(REVOLUTIONS),
             "--dt-factor", f"{factor:g}", "--seed", str(seed), "--threads", "1", "--checkpoint-every", "20",
             "--quiet", "--out", out, *resume])


def make_runs(args):
    os.makedirs(args.dir, exist_ok=True)
    todo = [(system, factor, seed) for seed in seeds_of(args.seeds) for system in args.systems.split(",")
            for factor in _factors(args) if not finished(run_path(system, factor, seed, args.dir))]
    print(f"{len(todo)} runs to make, {args.jobs} at a time", flush=True)

    def one(task):
        cmd = command(*task, args.dir)
        result = subprocess.run(cmd, capture_output=True, text=True)
        print(f"[{result.returncode}] {' '.join(cmd[2:])}" + (f"\n{result.stderr}" if result.returncode else ""),
              flush=True)

    with ThreadPoolExecutor(args.jobs) as pool:
        list(pool.map(one, todo))


def _factors(args):
    return [float(x) for x in args.factors.split(",")]


def study_table(args):
    """Print the table of every system and factor and the largest factor within two errors."""
    window = tuple(float(x) for x in args.window.split(":"))
    for system in args.systems.split(","):
        groups = {}
        for factor in _factors(args):
            paths = [run_path(system, factor, s, args.dir) for s in seeds_of(args.seeds)]
            paths = [p for p in paths if finished(p)]
            if paths:
                groups[f"{factor:g}"] = paths
        if "1" not in groups:
            print(f"{system}: no finished run at the paper's step (factor 1)")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # D/d 11.2 is below the confinement rule on purpose
            t = confinement_table(list(groups.values()), window, labels=list(groups)).set_index("label")
        ref = t.loc["1"]
        print(f"\n### {SYSTEMS[system]}: window [{window[0]:g}, {window[1]:g}] revolutions, mean ± replica s.e.; "
              "(deviation from factor 1 in combined s.e.)\n")
        print("| Δt factor | seeds | t_c/Δt | " + " | ".join(name for _, name, _ in COLUMNS) + " | cost [s] |")
        print("| --- " * (len(COLUMNS) + 4) + "|")
        agree = {}
        for label, row in t.iterrows():
            cells, worst = [], 0.0
            for column, _, digits in COLUMNS:
                value, err = row[column], row[f"{column}_err"]
                sigma = (value - ref[column]) / math.hypot(err, ref[f"{column}_err"])
                worst = max(worst, abs(sigma)) if label != "1" else 0.0
                cells.append(f"{value:.{digits}f} ± {err:.{digits}f}" + (f" ({sigma:+.1f})" if label != "1" else ""))
            agree[float(label)] = worst
            steps = _steps_per_contact(groups[label][0])
            print(f"| {label} | {int(row['n_replicas'])} | {steps:.0f} | " + " | ".join(cells) +
                  f" | {float(wall_times(groups[label]).mean()):.0f} |")
        within = [f for f in sorted(agree) if f >= 1 and all(agree[g] <= 2 for g in agree if 1 <= g <= f)]
        print(f"\n{system}: largest factor within 2 combined s.e. of factor 1 on every figure (and every factor "
              f"below it): {max(within):g}" if within else f"\n{system}: no factor above 1 agrees")


def _steps_per_contact(path):
    with ga.open_run(path) as run:
        return float((run.meta.sim_config or {}).get("steps_per_contact", math.nan))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    for name in ("run", "table"):
        p = sub.add_parser(name)
        p.add_argument("--seeds", default="0-9")
        p.add_argument("--systems", default=",".join(SYSTEMS))
        p.add_argument("--factors", default=FACTORS)
        p.add_argument("--dir", default="build/timestep")
        p.add_argument("--window", default="2:4")
        p.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    {"run": make_runs, "table": study_table}[args.what](args)


if __name__ == "__main__":
    main()
