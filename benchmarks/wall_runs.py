"""Our side of the wall experiments beside YADE: the lab-cg2 drum with YADE's physics (fixed bridge
volume, no viscous force) for several γ and seeds, with the smooth cylinder or YADE's facet polygon,
run in parallel, each kept as the float32 subset that ``benchmarks/yade_side_by_side.py`` reads
(never needed by the tests).

Usage (from anywhere; the commands run in the repository root)::

    python benchmarks/wall_runs.py [--cylinder-facets 96] [--no-wall-bridges] [--gammas 0.03,0.1095,0.444]
        [--seeds 0-4] [--workers 2] [--revolutions 3] [--out build/walls] [--keep benchmarks/yade_runs/walls]

Each case TAG = ``LABEL-g<γ>-s<seed>`` (LABEL ``sim``, then ``-f<N>`` for N facets, ``-drywalls``
without wall bridges) runs ``python -m sim run --preset lab-cg2 --bridge-volume 1e-12 --no-viscous
--gamma γ --seed S --revolutions R --cylinder-facets N [--no-wall-bridges] --threads 1 --quiet --out
OUT/TAG.h5`` (the command of ``benchmarks/yade_series.py``'s step (a) with the wall switched) and
then ``granalytics subset OUT/TAG.h5 --out KEEP/TAG.h5 --float32 --full-window 1:3 --every 4``.
A case whose kept subset exists is skipped. ``--workers`` runs that many cases at once, one core
each: on a 2-core machine keep it at 1 or 2 (about 2 minutes a case on a free core).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def seeds(text):
    """``"0-4"`` or ``"0,2,5"`` as a list of int."""
    if "-" in text:
        lo, hi = text.split("-")
        return list(range(int(lo), int(hi) + 1))
    return [int(s) for s in text.split(",")]


def run_case(gamma, seed, args):
    """Our run and its kept subset; returns a one-line report with the cost."""
    label = "sim" + (f"-f{args.cylinder_facets}" if args.cylinder_facets else "") + \
        ("-drywalls" if args.no_wall_bridges else "")
    tag = f"{label}-g{gamma:g}-s{seed}"
    full, kept = os.path.join(args.out, f"{tag}.h5"), os.path.join(args.keep, f"{tag}.h5")
    if os.path.exists(kept):
        return f"{tag}: kept subset exists, skipped"
    t0 = time.perf_counter()
    run = [sys.executable, "-m", "sim", "run", "--preset", "lab-cg2", "--bridge-volume", "1e-12", "--no-viscous",
           "--gamma", f"{gamma:g}", "--seed", str(seed), "--revolutions", f"{args.revolutions:g}",
           "--cylinder-facets", str(args.cylinder_facets), "--threads", "1", "--quiet", "--out", full] + \
        (["--no-wall-bridges"] if args.no_wall_bridges else [])
    if os.path.exists(full):
        run.append("--resume")
    done = subprocess.run(run, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        return f"{tag}: FAILED ({done.returncode}): {done.stderr.strip()[-300:]}"
    wall = time.perf_counter() - t0
    subset = [sys.executable, "-m", "granalytics", "subset", full, "--out", kept, "--float32", "--full-window",
              "1:3", "--every", "4", "--quiet"]
    done = subprocess.run(subset, cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        return f"{tag}: subset FAILED ({done.returncode}): {done.stderr.strip()[-300:]}"
    return f"{tag}: run {wall:.0f} s wall on one core; kept {kept}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cylinder-facets", type=int, default=0, help="0: smooth (default); N >= 3: YADE's polygon")
    parser.add_argument("--no-wall-bridges", action="store_true", help="dry walls: no bridges with them")
    parser.add_argument("--gammas", default="0.03,0.1095,0.444", help="γ of the original system [N/m]")
    parser.add_argument("--seeds", type=seeds, default=seeds("0-4"), help="seeds of our filling (0-4)")
    parser.add_argument("--revolutions", type=float, default=3.0)
    parser.add_argument("--workers", type=int, default=1, help="cases at once, one core each (1)")
    parser.add_argument("--out", default="build/walls", help="folder of the full runs")
    parser.add_argument("--keep", default="benchmarks/yade_runs/walls", help="folder of the kept subsets")
    args = parser.parse_args(argv)
    args.out, args.keep = (os.path.join(ROOT, p) if not os.path.isabs(p) else p for p in (args.out, args.keep))
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.keep, exist_ok=True)
    cases = [(float(g), s) for g in args.gammas.split(",") for s in args.seeds]
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max_workers=args.workers) as pool:
        for line in pool.map(lambda case: run_case(*case, args), cases):
            print(line, flush=True)
    print(f"{len(cases)} cases in {time.perf_counter() - t0:.0f} s with {args.workers} worker(s)")


if __name__ == "__main__":
    main()
