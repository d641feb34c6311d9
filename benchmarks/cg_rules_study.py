"""The CG rules compared: Table 2 (``weber``) against the Bond-preserving rule (``bond``) in the lab
drum family at equal confinement, with the α = 1 twin of the Bond CG3 system as the check that a
CG run is its original system in other units.

Usage::

    python benchmarks/cg_rules_study.py run [--seeds 0-4] [--systems cg1,cg3-bond,...] [--dir build/cg-rules]
    python benchmarks/cg_rules_study.py table [--seeds 0-4] [--window 3:6] [--dir build/cg-rules] [--figures DIR]
    python benchmarks/cg_rules_study.py paper [--window 3:6]

``run`` makes the missing runs one after the other on one thread (``python -m sim run``; an
interrupted run resumes from its checkpoint), seed by seed so that a half-made series is
balanced. ``table`` prints, for the angle and the rigid co-motion tests, every system's steady
yield, ⟨V_g⟩/V_p and N_g/N (mean ± replica s.e. over the seeds), the flowing bed (wall share,
coordination, bed angle, kinetic energy per mass over the rim speed squared), the deviations from
CG1 and each run's cost. ``paper`` compares the paper-drum CG runs under both rules (bundled
paper-cg2/paper-cg3 under ``weber``; ``build/runs/paper-cg3-bond.h5``, made by the command printed
there).

All lab systems are the lab drum's geometry at D/d = 11.2 of the simulated particles (111 of
them), so the CG runs are compared with α = 1 runs at the same confinement: what remains is the
error of the scaling rules alone.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import warnings

import numpy as np

import granalytics as ga
from granalytics.analysis.confinement import confinement_table

#: the lab systems: name -> the options of ``python -m sim run`` beyond revolutions, seed and output
SYSTEMS = {
    "cg1": "--preset lab-cg1 --drum-ratio 11.2",
    "cg2-weber": "--preset lab-cg2 --drum-ratio 11.2 --cg-rule weber",
    "cg2-bond": "--preset lab-cg2 --drum-ratio 11.2 --cg-rule bond",
    "cg3-weber": "--preset lab-cg3 --drum-ratio 11.2 --cg-rule weber",
    "cg3-bond": "--preset lab-cg3 --drum-ratio 11.2 --cg-rule bond",
    "twin3-bond": "--preset lab-cg3 --drum-ratio 11.2 --cg-rule bond --twin",
}
REVOLUTIONS = 6
CRITERIA = {"angle": {}, "rigid": {"comotion": "rigid"}}
COLUMNS = (("yield_fraction", "yield", 3), ("mean_volume_norm", "⟨V_g⟩/V_p", 2), ("n_granules_norm", "N_g/N", 3),
           ("wall_share", "wall share", 2), ("coordination", "coordination", 2), ("bed_angle_deg", "bed angle [°]", 1),
           ("kinetic_energy_norm", "KE/m/(ΩR_d)²", 3))
PAPER_BOND = "build/runs/paper-cg3-bond.h5"
PAPER_BOND_COMMAND = (f"python -m sim run --preset paper-cg3 --cg-rule bond --revolutions 6 --seed 0 --threads 1 "
                      f"--checkpoint-every 2 --quiet --out {PAPER_BOND}")


def command(system, seed, folder):
    out = run_path(system, seed, folder)
    resume = "--resume" if os.path.exists(f"{out}.ckpt.npz") else ""
    return (f"{sys.executable} -m sim run {SYSTEMS[system]} --revolutions {REVOLUTIONS} --seed {seed} --threads 1 "
            f"--checkpoint-every 10 --quiet --out {out} {resume}").split()


def run_path(system, seed, folder):
    return os.path.join(folder, f"{system}-seed{seed}.h5")


def finished(path):
    if not os.path.exists(path):
        return False
    try:
        with ga.open_run(path) as run:
            return not run.unfinished
    except ga.GranalyticsError:
        return False


def seeds_of(text):
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def make_runs(args):
    os.makedirs(args.dir, exist_ok=True)
    for seed in seeds_of(args.seeds):
        for system in args.systems.split(","):
            path = run_path(system, seed, args.dir)
            if finished(path):
                continue
            print(" ".join(command(system, seed, args.dir)), flush=True)
            subprocess.run(command(system, seed, args.dir), check=True)


def _fmt(value, err, digits):
    return f"{value:.{digits}f} ± {err:.{digits}f}" if math.isfinite(err) else f"{value:.{digits}f}"


def _deviation(value, err, ref, ref_err):
    dev = value / ref - 1
    se = abs(value / ref) * math.hypot(err / value if value else 0, ref_err / ref if ref else 0)
    return f"{100 * dev:+.0f} ± {100 * se:.0f} %"


def wall_times(paths):
    times = []
    for path in paths:
        with ga.open_run(path) as run:
            times.append(float(run.meta.provenance.get("wall_time_s") or math.nan))
    return np.array(times)


def table(groups, window, reference="cg1", twin_pairs=(("cg3-bond", "twin3-bond"),)):
    """Print the Markdown tables of ``groups`` (label -> run paths) under both co-motion tests."""
    costs = {label: wall_times(paths) for label, paths in groups.items()}
    for criterion, params in CRITERIA.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # D/d 11.2 is below the confinement rule on purpose
            t = confinement_table(list(groups.values()), window, labels=list(groups), **params).set_index("label")
        print(f"\n### {criterion} co-motion test, window [{window[0]:g}, {window[1]:g}] revolutions "
              "(mean ± replica s.e.; deviation from CG1)\n")
        print("| system | seeds | " + " | ".join(name for _, name, _ in COLUMNS) + " | yield vs CG1 | ⟨V_g⟩/V_p vs CG1 |")
        print("| --- " * (len(COLUMNS) + 4) + "|")
        ref = t.loc[reference] if reference in t.index else None
        for label, row in t.iterrows():
            cells = [_fmt(row[c], row[f"{c}_err"], d) for c, _, d in COLUMNS]
            devs = ([_deviation(row[c], row[f"{c}_err"], ref[c], ref[f"{c}_err"])
                     for c in ("yield_fraction", "mean_volume_norm")] if ref is not None else ["", ""])
            print(f"| {label} | {int(row['n_replicas'])} | " + " | ".join(cells) + " | " + " | ".join(devs) + " |")
        for cg, twin in twin_pairs:
            if cg in t.index and twin in t.index:
                a, b = t.loc[cg], t.loc[twin]
                print(f"\n{cg} against its α = 1 twin {twin}: yield "
                      f"{_deviation(a['yield_fraction'], a['yield_fraction_err'], b['yield_fraction'], b['yield_fraction_err'])}, "
                      f"⟨V_g⟩/V_p {_deviation(a['mean_volume_norm'], a['mean_volume_norm_err'], b['mean_volume_norm'], b['mean_volume_norm_err'])}")
    print("\n### cost (wall time of one run, 1 thread, mean over seeds; speed-up against CG1)\n")
    print("| system | wall time [s] | speed-up |")
    print("| --- | --- | --- |")
    ref_cost = np.nanmean(costs[reference]) if reference in costs else math.nan
    for label, times in costs.items():
        print(f"| {label} | {np.nanmean(times):.0f} | {ref_cost / np.nanmean(times):.2f}× |")


def size_table(groups, window, figures=None, reference="cg1"):
    """The pooled granule sizes of the window (angle test) in original-particle equivalents α³·n:
    mean, median, 90th percentile and the KS distance to the reference; with ``figures`` the
    CG comparison's figures (Figs 3-6, sizes in α³·n) are written there."""
    from scipy.stats import ks_2samp

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cg = ga.compare_cg(list(groups.values()), list(groups), window=window, mixed_systems=True)  # the twin
    alphas = cg.runs.set_index("run")["alpha"]
    ref = cg.sizes[reference] * alphas[reference] ** 3
    print(f"\n### granule sizes in original-particle equivalents α³·n (angle test, pooled over the window and the "
          f"seeds; KS distance to {reference})\n")
    print("| system | granules | mean | median | 90th percentile | KS distance |")
    print("| --- | --- | --- | --- | --- | --- |")
    for label, sizes in cg.sizes.items():
        original = sizes * alphas[label] ** 3
        print(f"| {label} | {sizes.size} | {original.mean():.1f} | {np.median(original):.0f} | "
              f"{np.percentile(original, 90):.0f} | {ks_2samp(original, ref).statistic:.3f} |")
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        written = ga.save(cg, figures, overwrite=True, size_unit="original")
        print("\n" + "\n".join(map(str, written)))


def lab_table(args):
    window = tuple(float(x) for x in args.window.split(":"))
    groups = {}
    for system in SYSTEMS:
        paths = [run_path(system, s, args.dir) for s in seeds_of(args.seeds) if finished(run_path(system, s, args.dir))]
        if paths:
            groups[system] = paths
    table(groups, window)
    size_table(groups, window, args.figures)


def paper_table(args):
    from granalytics.datasets import dataset_path

    window = tuple(float(x) for x in args.window.split(":"))
    groups = {"paper-cg2 (weber)": [dataset_path("paper-cg2")], "paper-cg3 (weber)": [dataset_path("paper-cg3")]}
    if finished(PAPER_BOND):
        groups["paper-cg3 (bond)"] = [PAPER_BOND]
    else:
        print(f"{PAPER_BOND} missing or unfinished; made by: {PAPER_BOND_COMMAND}")
    table(groups, window, reference="paper-cg2 (weber)", twin_pairs=())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    for name in ("run", "table", "paper"):
        p = sub.add_parser(name)
        p.add_argument("--seeds", default="0-4")
        p.add_argument("--systems", default=",".join(SYSTEMS))
        p.add_argument("--dir", default="build/cg-rules")
        p.add_argument("--window", default="3:6")
        p.add_argument("--figures", default=None, help="write the CG comparison's figures here (table)")
    args = parser.parse_args(argv)
    {"run": make_runs, "table": lab_table, "paper": paper_table}[args.what](args)


if __name__ == "__main__":
    main()
