"""Do the bundled runs that an older simulator physics version made still hold? Remake a replica
set with today's simulator (the recipes' own simulation commands, output under build/recheck/)
and compare its steady state with the bundled set's, metric by metric, in units of the combined
replica standard error.

Usage::

    python benchmarks/dataset_recheck.py run [--sets lab-cg3,lab-cg2]     # the missing fresh runs, one by one
    python benchmarks/dataset_recheck.py table [--sets lab-cg3,lab-cg2] [--window 3:6]

The table's last column is what ``granalytics.datasets.PHYSICS_RECHECKS`` records for each set.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import subprocess
import sys
import warnings

import granalytics as ga
from granalytics.analysis.metrics import HEADLINE
from granalytics.datasets import DATASETS, REPLICAS, replica_paths

FOLDER = "build/recheck"


def fresh_command(name):
    """The recipe's simulation command of dataset ``name``, writing to build/recheck/NAME.h5."""
    argv = shlex.split(DATASETS[name]["commands"][0])
    argv[argv.index("--out") + 1] = os.path.join(FOLDER, f"{name}.h5")
    if os.path.exists(os.path.join(FOLDER, f"{name}.h5.ckpt.npz")):
        argv.append("--resume")
    return [sys.executable, *argv[1:]]


def fresh_paths(replica_set):
    return [os.path.join(FOLDER, f"{name}.h5") for name in REPLICAS[replica_set]]


def make_runs(args):
    os.makedirs(FOLDER, exist_ok=True)
    for replica_set in args.sets.split(","):
        for name, path in zip(REPLICAS[replica_set], fresh_paths(replica_set)):
            done = False
            if os.path.exists(path):
                with ga.open_run(path, validate=False) as run:
                    done = not run.unfinished
            if not done:
                print(" ".join(fresh_command(name)), flush=True)
                subprocess.run(fresh_command(name), check=True)


def steady(paths, window):
    series = []
    for path in paths:
        with ga.open_run(path) as run, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            series.append(ga.run_stats(run.select(revolutions=window)))
    return ga.replica_steady_state(series, window=window), series


def table(args):
    window = tuple(float(x) for x in args.window.split(":"))
    print("| set | physics | " + " | ".join(HEADLINE) + " | largest |difference| / s.e. |")
    print("| --- | --- | " + "--- | " * len(HEADLINE) + "--- |")
    for replica_set in args.sets.split(","):
        bundled, _ = steady(replica_paths(replica_set), window)
        fresh, _ = steady(fresh_paths(replica_set), window)
        worst = 0.0
        cells = {"bundled": [], "fresh": []}
        with ga.open_run(replica_paths(replica_set)[0]) as run:
            old = run.meta.provenance.get("physics_version")
        with ga.open_run(fresh_paths(replica_set)[0]) as run:
            new = run.meta.provenance.get("physics_version")
        for metric in HEADLINE:
            for label, t in (("bundled", bundled), ("fresh", fresh)):
                cells[label].append(f"{t.loc[metric, 'mean']:.4g} ± {t.loc[metric, 'replica_sem']:.2g}")
            se = math.hypot(bundled.loc[metric, "replica_sem"], fresh.loc[metric, "replica_sem"])
            worst = max(worst, abs(bundled.loc[metric, "mean"] - fresh.loc[metric, "mean"]) / se)
        print(f"| {replica_set} bundled | {old} | " + " | ".join(cells["bundled"]) + " | |")
        print(f"| {replica_set} fresh | {new} | " + " | ".join(cells["fresh"]) + f" | {worst:.1f} |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=("run", "table"))
    parser.add_argument("--sets", default="lab-cg3,lab-cg2")
    parser.add_argument("--window", default="3:6")
    args = parser.parse_args(argv)
    {"run": make_runs, "table": table}[args.what](args)


if __name__ == "__main__":
    main()
