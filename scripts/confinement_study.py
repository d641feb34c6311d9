"""Confinement against coarse-graining: the tables and figure of docs/results.md, "Confinement".

Usage: python scripts/confinement_study.py [--figures DIR] [--parts table,decomposition,passrate,minsize]
       python scripts/confinement_study.py --check-rule

Every run on the α = 1 confinement curve is a run of the lab drum's geometry rule sized for a
particle count (``python -m sim run --preset lab-cg1 --drum-particles N``) or a D/d
(``--drum-ratio``); the runs are not bundled (the 100 MB budget): build/runs/confinement/, made by the registry's
recipes, ``granalytics.datasets.CONFINEMENT``). Prints Markdown tables; with --figures writes
confinement_yield.png (yield, ⟨V_g⟩/V_p and N_g/N against D/d, one marker per α, replica bars, the
fitted finite-size law).
"""

from __future__ import annotations

import argparse
import math
import os
import warnings

import numpy as np
import pandas as pd

import granalytics as ga
from granalytics.identification.contacts import co_moving, co_moving_rigid, contact_strength
from granalytics.datasets import confinement_groups, dataset_path, replica_paths

#: the criteria compared: the paper's angle test and the rigid-pair test at its defaults
CRITERIA = {"angle": {}, "rigid": {"comotion": "rigid"}}
#: steady windows: the paper's [3, 6] (runs that end sooner: their last revolution); [1, 2], the
#: window every run has
WINDOWS = {"[3, 6]": (3.0, 6.0), "[1, 2]": (1.0, 2.0)}
METRICS = (("yield_fraction", "yield"), ("mean_volume_norm", "⟨V_g⟩/V_p"), ("n_granules_norm", "N_g/N"))


def _fmt(value, err, digits=3):
    return f"{value:.{digits}f} ± {err:.{digits}f}" if np.isfinite(err) else f"{value:.{digits}f}"


def cg_groups():
    """label -> list of run paths of the CG runs (lab with replicas, the paper drum)."""
    return {
        "lab-cg1": [dataset_path("lab-cg1")],
        "lab-cg2": replica_paths("lab-cg2"), "lab-cg3": replica_paths("lab-cg3"),
        "paper-cg2": [dataset_path("paper-cg2")], "paper-cg3": [dataset_path("paper-cg3")],
    }


def run_window(path, window):
    """``window`` where the run covers it; else the run's last complete revolution [R − 1, R]
    (R = its revolutions rounded down: a run being extended keeps its window until it completes the
    next revolution)."""
    with ga.open_run(path) as run:
        last = float(run.revolutions[-1])
    if last >= window[1] - 0.01:
        return window
    whole = float(math.floor(last + 0.01))
    return (whole - 1.0, whole)


def tables(window):
    """The confinement table of every run (CG1 curve, its Froude-matched twins, the CG runs) under
    both criteria, in a window. A run that ends before the window's end is taken over its last
    complete revolution [R − 1, R] (the D/d = 50 run: [2, 3] while it has three; lab-cg1 gives the same yield
    over [1, 2] as over [3, 6], 0.555 against 0.553); paper-cg2 (3 revolutions) over [2, 3]."""
    groups = {**confinement_groups(), **cg_groups()}
    out = {}
    for name, params in CRITERIA.items():
        rows = []
        for label, paths in groups.items():
            w = run_window(paths[0], window)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the confinement warning: this table is what it is about
                rows.append(ga.confinement_table([paths], window=w, labels=[label], **params)
                            .assign(window=f"[{w[0]:g}, {w[1]:g}]"))
        out[name] = pd.concat(rows, ignore_index=True)
    return out


def print_table(table, title):
    print(f"\n{title}\n")
    print("| run | α | N | replicas | window | D/d | L/d | bed depth/d | wall share | coordination | yield | "
          "⟨V_g⟩/V_p | N_g/N |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in table.itertuples(index=False):
        print(f"| {r.label} | {r.alpha:g} | {r.n_particles} | {r.n_replicas} | {r.window} | {r.drum_ratio:.1f} | "
              f"{r.length_ratio:.1f} | {r.bed_depth_ratio:.1f} | {_fmt(r.wall_share, r.wall_share_err)} | "
              f"{_fmt(r.coordination, r.coordination_err, 2)} | {_fmt(r.yield_fraction, r.yield_fraction_err)} | "
              f"{_fmt(r.mean_volume_norm, r.mean_volume_norm_err, 2)} | {_fmt(r.n_granules_norm, r.n_granules_norm_err, 4)} |")


def curve_points(table):
    """The α = 1 curve's rows at the drum's own Ω (not the Froude-matched twins)."""
    return table[(table["alpha"] == 1) & ~table["label"].str.contains("-fr")].sort_values("drum_ratio")


def fits(table):
    """metric -> ConfinementFit of the α = 1 curve."""
    curve = curve_points(table)
    return {m: ga.fit_confinement_curve(curve["drum_ratio"], curve[m], np.maximum(curve[f"{m}_err"], 1e-4))
            for m, _ in METRICS}


def print_fits(fitted, criterion, window):
    print(f"\nα = 1 confinement curve, {criterion} test, window {window}: y = y∞·(1 − b/(D/d))\n")
    print("| metric | y∞ | b [d] | χ²/dof | D/d within 5 % | D/d within 10 % | curve at D/d = 133 (paper CG1) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for metric, label in METRICS:
        f = fitted[metric]
        x5, s5 = f.within(0.05)
        x10, s10 = f.within(0.10)
        print(f"| {label} | {f.y_inf:.3f} ± {np.sqrt(f.covariance[0, 0]):.3f} | {f.b:.2f} ± "
              f"{np.sqrt(f.covariance[1, 1]):.2f} | {f.chi2:.1f}/{f.dof} | {x5:.0f} ± {s5:.0f} | {x10:.0f} ± {s10:.0f} | "
              f"{float(f(133.3)):.3f} ± {float(f.error(133.3)):.3f} |")


def print_decomposition(table, fitted, criterion, window):
    rows = table[table["label"].isin(["lab-cg2", "lab-cg3", "paper-cg2", "paper-cg3"])]
    if rows.empty:
        return
    print(f"\nDecomposition, {criterion} test, window {window}: deviation from CG1 at equal D/d (the scaling rules' "
          "error) and at equal drum (what a user gets; paper drum: the α = 1 curve at the paper CG1's D/d = 133, "
          "an extrapolation)\n")
    print("| run | D/d | metric | CG run | CG1 at equal D/d | deviation at equal D/d | CG1 in the same drum | "
          "deviation at equal drum |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    lab = table[table["label"] == "lab-cg1"]
    for metric, label in METRICS:
        f = fitted[metric]
        same = {}
        for r in rows.itertuples(index=False):
            if r.label.startswith("lab") and not lab.empty:
                same[r.label] = (float(lab[metric].iloc[0]), float(lab[f"{metric}_err"].iloc[0]))
            else:
                same[r.label] = (float(f(133.3)), float(f.error(133.3)))
        split = ga.decompose_cg(rows, f, same, metric)
        for s in split.itertuples(index=False):
            print(f"| {s.label} | {s.drum_ratio:.1f} | {label} | {_fmt(s.value, s.value_err)} | "
                  f"{_fmt(s.cg1_equal_dd, s.cg1_equal_dd_err)} | {100 * s.dev_equal_dd:+.0f} % ± {100 * s.dev_equal_dd_err:.0f} % | "
                  f"{s.cg1_same_drum:.3f} | {100 * s.dev_same_drum:+.0f} % ± {100 * s.dev_same_drum_err:.0f} % |")


def pass_rates():
    """Share of force-passing contacts (f ≥ 0.6, acting) that pass each co-motion test, per run."""
    print("\nCo-motion pass rate of force-passing contacts (F_coh ≥ 0.6·2πγR, acting; lab and paper-cg3 "
          "revolutions [3, 4], paper-cg2 [2, 3]; ± the spread over frames / √frames)\n")
    print("| run | α | D/d | angle test (A_agg = 20°) | rigid test (0.2 √(g d)) | rigid, drum scale (0.05 Ω R_d) |")
    print("| --- | --- | --- | --- | --- | --- |")
    runs = {"lab-cg1": dataset_path("lab-cg1"), "lab-cg2": dataset_path("lab-cg2"), "lab-cg3": dataset_path("lab-cg3"),
            "paper-cg2": dataset_path("paper-cg2"), "paper-cg3": dataset_path("paper-cg3"),
            **{k: v[0] for k, v in confinement_groups().items() if "-fr" not in k}}
    for label, path in runs.items():
        window = run_window(path, (3.0, 4.0))
        with ga.open_run(path) as run:
            rates = []
            for s in run.select(revolutions=window):
                strong = contact_strength(s) >= 0.6
                rates.append([co_moving(s, 20.0)[strong].mean(), co_moving_rigid(s)[strong].mean(),
                              co_moving_rigid(s, 0.05, "drum")[strong].mean()])
            rates = np.array(rates)
            mean, err = rates.mean(axis=0), rates.std(axis=0, ddof=1) / np.sqrt(len(rates))
            drum = ga.confinement_of_run(run.meta)
            print(f"| {label} | {run.meta.alpha:g} | {drum.drum_ratio:.1f} | " +
                  " | ".join(_fmt(m, e) for m, e in zip(mean, err)) + " |")


def min_size_table():
    print("\nGranule size floor (paper drum, acting, paper thresholds, angle test; paper-cg3 window [3, 6], "
          "paper-cg2 [2, 3])\n")
    print("| run | min_size | yield | ⟨V_g⟩/V_p | N_g/N |")
    print("| --- | --- | --- | --- | --- |")
    for label, window in (("paper-cg3", (3.0, 6.0)), ("paper-cg2", (2.0, 3.0))):
        with ga.open_run(dataset_path(label)) as run:
            frames = run.select(revolutions=window)
            table = ga.sensitivity(frames, c_agg=[0.6], a_agg_deg=[20.0], min_size=2)
            for k in (3, 5):
                table = pd.concat([table, ga.sensitivity(frames, c_agg=[0.6], a_agg_deg=[20.0], min_size=k)
                                   .assign(min_size=k)])
        table["min_size"] = table["min_size"].fillna(2).astype(int)
        for k, part in table.groupby("min_size"):
            steady = ga.steady_state(part, window, ("yield_fraction", "mean_volume_norm", "n_granules_norm"))
            cells = [_fmt(steady.loc[m, "mean"], steady.loc[m, "sem"], 2 if m == "mean_volume_norm" else 4 if m == "n_granules_norm" else 3)
                     for m in ("yield_fraction", "mean_volume_norm", "n_granules_norm")]
            print(f"| {label} | {k} | " + " | ".join(cells) + " |")


def figure(results, path):
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), layout="constrained")
    markers = {1.0: "o", 2.0: "s", 3.0: "^"}
    for row, (criterion, (table, fitted)) in enumerate(results.items()):
        for col, (metric, label) in enumerate(METRICS):
            ax = axes[row, col]
            for r in table.itertuples(index=False):
                froude = "-fr" in r.label
                colour = "C3" if r.label.startswith("paper") else ("C4" if froude else f"C{int(r.alpha) - 1}")
                ax.errorbar(r.drum_ratio, getattr(r, metric), yerr=getattr(r, f"{metric}_err"),
                            marker=markers.get(r.alpha, "D"), color=colour, mfc="none" if froude else colour,
                            ms=7, capsize=3, ls="none")
            f = fitted[metric]
            x = np.linspace(8, 140, 300)
            ax.plot(x, f(x), "k-", lw=1, label=f"α = 1 fit y∞·(1 − b/(D/d)): y∞ = {f.y_inf:.3g}, b = {f.b:.2g}, "
                                               f"χ²/dof = {f.chi2:.0f}/{f.dof}")
            ax.fill_between(x, f(x) - f.error(x), f(x) + f.error(x), color="k", alpha=0.1, lw=0)
            ax.set_xscale("log")
            ax.set_xlabel("D/d (drum diameter / particle diameter)")
            ax.set_ylabel(label)
            ax.set_title(f"{label}, {criterion} co-motion test", fontsize=10)
            ax.legend(fontsize=7, loc="best")
    handles = [plt.Line2D([], [], marker=markers[a], color=f"C{int(a) - 1}", ls="none", label=f"lab drum, α = {a:g}")
               for a in (1.0, 2.0, 3.0)]
    handles += [plt.Line2D([], [], marker="o", color="C4", mfc="none", ls="none", label="α = 1, Froude-matched Ω"),
                plt.Line2D([], [], marker="s", color="C3", ls="none", label="paper drum (α = 2 square, 3 triangle)")]
    fig.legend(handles=handles, loc="outside lower center", ncol=5, fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"\nwrote {path}")


def check_rule() -> int:
    """Whether :data:`granalytics.CONFINEMENT_RULE`'s lab drum family is the fit of the α = 1 runs (window [3, 6],
    angle test), and whether each confinement group is one system at several seeds; prints both,
    returns 1 where either fails (the runs take hours, so this is a check to run, not a test)."""
    import granalytics.analysis.confinement as confinement

    failed = 0
    fit = fits(tables((3.0, 6.0))["angle"])["yield_fraction"]
    rule = fit.rule()
    for key, fraction in (("within_5pc", 0.05), ("within_10pc", 0.10)):
        x, err = fit.within(fraction)
        kept = confinement.CONFINEMENT_RULE["lab drum"][key]
        ok = kept == rule[key]
        failed += not ok
        print(f"{key}: fit {x:.0f} ± {err:.0f}, CONFINEMENT_RULE['lab drum'] {kept}: "
              f"{'agrees' if ok else 'DIFFERS'}")
    for label, paths in confinement_groups().items():
        systems = {repr(sorted((k, v) for k, v in ga.open_run(p).meta.sim_config["params"].items() if k != "seed"))
                   for p in paths}
        failed += len(systems) != 1
        print(f"{label}: {len(paths)} run(s), {'one system' if len(systems) == 1 else 'SEVERAL systems'}")
    return 1 if failed else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", help="folder for confinement_yield.png")
    parser.add_argument("--parts", default="table,decomposition,passrate,minsize",
                        help="which parts: table, decomposition, passrate, minsize (default all)")
    parser.add_argument("--check-rule", action="store_true",
                        help="only check that CONFINEMENT_RULE is the fit of the runs and each group one system")
    args = parser.parse_args()
    if args.check_rule:
        raise SystemExit(check_rule())
    parts = set(args.parts.split(","))
    if parts & {"table", "decomposition"}:
        for wname, window in WINDOWS.items():
            results = {}
            for criterion, table in tables(window).items():
                fitted = fits(table)
                results[criterion] = (table, fitted)
                if "table" in parts:
                    print_table(table, f"Confinement table, {criterion} co-motion test, window {wname} (a run that ends "
                                       "sooner: its last revolution); ± replica s.e. for groups, block s.e.m. for one run")
                    print_fits(fitted, criterion, wname)
                if "decomposition" in parts:
                    print_decomposition(table, fitted, criterion, wname)
            if args.figures and wname == "[3, 6]":
                os.makedirs(args.figures, exist_ok=True)
                figure(results, os.path.join(args.figures, "confinement_yield.png"))
    if "passrate" in parts:
        pass_rates()
    if "minsize" in parts:
        min_size_table()


if __name__ == "__main__":
    main()
