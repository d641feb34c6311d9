"""The population balance against the DEM, and its rates under coarse-graining (docs/population_balance.md).

    python scripts/population_balance_study.py [--out build/pbm-study] [--figures docs/figures]

1. Prediction: rates measured on revolutions [1, 2] and [2, 3] of lab-cg1, paper-cg3 and
   paper-cg2 (GNA at the paper's thresholds, acting cohesion, min_fragment 2) predict the size
   distribution from the start of the next window; the PBM beside the DEM at two later times (KS D,
   mean size, yield), with the persistence baseline (the DEM's first frame taken as the prediction)
   and the DEM's own frame-to-frame spread. Writes prediction.csv and pbm_prediction.png.
2. CG: the rates of lab-cg1, lab-cg2 and lab-cg3 on revolutions [3, 6] (every frame, 0.05
   revolution), and of paper-cg2 and paper-cg3 on [2, 3] (0.2 revolution), against the
   original-particle-equivalent granule size α³·n. Writes cg_kernels.csv and pbm_cg_kernels.png.

Prints both tables as markdown. About a minute here (two cores).
"""

from __future__ import annotations

import argparse
import math
import os
import warnings

import numpy as np
import pandas as pd

import granalytics as ga
from granalytics.datasets import open_dataset

#: (run, fit window, prediction window, the two later revolutions reported)
CASES = [
    ("lab-cg1", (1, 2), (2, 6), (4, 6)),
    ("lab-cg1", (2, 3), (3, 6), (4, 6)),
    ("paper-cg3", (1, 2), (2, 6), (4, 6)),
    ("paper-cg3", (2, 3), (3, 6), (4, 6)),
    ("paper-cg2", (1, 2), (2, 3), (2.6, 3)),
]
#: (run, CG factor α, window [revolutions]) of the kernel comparison
CG_RUNS = [("lab-cg1", 1, (3, 6)), ("lab-cg2", 2, (3, 6)), ("lab-cg3", 3, (3, 6)),
           ("paper-cg2", 2, (2, 3)), ("paper-cg3", 3, (2, 3))]


def prediction_table(progress=False):
    rows, predictions = [], {}
    for name, fit, window, times in CASES:
        with open_dataset(name) as run:
            pred = ga.pbm_from_run(run, fit, window, progress=progress)
        predictions[(name, fit)] = pred
        table = pred.summary()
        dem_pooled = pred.dem_numbers.sum(axis=0)
        for rev, row in zip(times, pred.at(times).itertuples()):
            i = int(np.argmin(np.abs(pred.revolutions - rev)))
            rows.append({
                "run": name, "fit_window": f"{fit[0]}–{fit[1]}", "start_rev": round(float(pred.revolutions[0]), 2),
                "rev": round(float(row.revolution), 2),
                "pbm_mean_size": row.pbm_mean_size, "dem_mean_size": row.dem_mean_size,
                "pbm_yield": row.pbm_yield_fraction, "dem_yield": row.dem_yield_fraction,
                "ks_d": row.ks_d, "ks_d_persistence": row.ks_d_persistence,
                # the DEM's own noise: this frame against the window's pooled frames
                "ks_d_dem_frame_vs_window": ga.ks_distance(pred.dem_numbers[i], dem_pooled, pred.pbm.grid),
                "dem_yield_window": f"{table.dem_yield_fraction.mean():.3f} ± {table.dem_yield_fraction.std():.3f}",
                "dem_mean_window": f"{table.dem_mean_size.mean():.2f} ± {table.dem_mean_size.std():.2f}",
                "pbm_mass_error": pred.pbm.mass_error,
            })
    return pd.DataFrame(rows), predictions


def prediction_figure(predictions, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(predictions), figsize=(3.6 * len(predictions), 6.5), layout="constrained",
                             squeeze=False)
    for k, ((name, fit), pred) in enumerate(predictions.items()):
        table = pred.summary()
        for row, (col, label) in enumerate((("mean_size", "mean granule size [particles]"),
                                            ("yield_fraction", "yield"))):
            ax = axes[row, k]
            ax.plot(table.revolution, table["dem_" + col], "o", ms=2.5, label="DEM")
            ax.plot(table.revolution, table["pbm_" + col], "-", lw=2, label="PBM")
            ax.set_xlabel("revolutions")
            if k == 0:
                ax.set_ylabel(label)
            if row == 0:
                ax.set_title(f"{name}, rates on {fit[0]}–{fit[1]}", fontsize=9)
            ax.legend(fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def cg_kernels(progress=False):
    rows = []
    for name, alpha, window in CG_RUNS:
        with open_dataset(name) as run:
            tracks = ga.track_run(run, window=window, progress=progress)
            n = run.meta.n_particles
        rates = ga.fit_pbm_rates(tracks, n)
        kern = rates.kernel
        classes = rates.classes[rates.classes.size_min >= 2].reset_index(drop=True)
        nc = len(classes)
        beta = np.zeros((nc, nc))
        beta[kern.class_i, kern.class_j] = np.nan_to_num(kern.beta_per_s)
        beta[kern.class_j, kern.class_i] = np.nan_to_num(kern.beta_per_s)
        events = np.zeros((nc, nc))
        events[kern.class_i, kern.class_j] = kern.n_events
        events[kern.class_j, kern.class_i] = kern.n_events
        n_mean = classes.n_mean.to_numpy()
        for i, c in classes.iterrows():
            lo, hi = int(c.size_min), int(c.size_max)
            rows.append({
                "run": name, "alpha": alpha, "window": f"{window[0]}–{window[1]}",
                "size_min": lo, "size_max": hi, "equiv_min": alpha ** 3 * lo, "equiv_max": alpha ** 3 * hi,
                "equiv_mid": alpha ** 3 * math.sqrt(lo * hi), "n_mean": c.n_mean,
                # the rate at which one granule of the class coalesces with any other [1/s]
                "coalescence_per_granule_s": float(beta[i] @ n_mean),
                "n_coalescence_events": int(events[i].sum()),
                "beta_diag_per_s": beta[i, i], "n_diag_events": int(events[i, i]),
                "selection_per_s": c.selection_rate_per_s, "n_breakage": int(c.n_breakage),
            })
    return pd.DataFrame(rows)


def cg_figure(table, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 4, figsize=(18, 4.3), layout="constrained")
    panels = (("coalescence_per_granule_s", "n_coalescence_events", "coalescences per granule Σ_j β(i,j)N̄_j [1/s]"),
              ("selection_per_s", "n_breakage", "selection rate S(i) [1/s]"),
              ("beta_diag_per_s", "n_diag_events", "β(i, i) [1/s per pair]"))
    for (name, alpha, _), colour in zip(CG_RUNS, ("k", "C0", "C1", "C2", "C3")):
        sub = table[table.run == name]
        marker = "o" if name.startswith("lab") else "s"
        fill = colour if name.startswith("lab") else "none"
        for ax, (col, ncol, label) in zip(axes, panels):
            ok = (sub[ncol] >= 3) & (sub[col] > 0)
            s = sub[ok]
            err = s[col] / np.sqrt(s[ncol])
            ax.errorbar(s.equiv_mid, s[col], yerr=err, xerr=None, fmt=marker + "-", color=colour, mfc=fill,
                        ms=5, lw=1, capsize=2, label=f"{name} (α = {alpha})")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("granule size in original particles α³·n")
            ax.set_ylabel(label)
        # the same coalescence frequency against the run's own particle count n
        s = sub[(sub.n_coalescence_events >= 3) & (sub.coalescence_per_granule_s > 0)]
        axes[3].errorbar(s.equiv_mid / alpha ** 3, s.coalescence_per_granule_s,
                         yerr=s.coalescence_per_granule_s / np.sqrt(s.n_coalescence_events), fmt=marker + "-",
                         color=colour, mfc=fill, ms=5, lw=1, capsize=2)
    axes[3].set_xscale("log")
    axes[3].set_yscale("log")
    axes[3].set_xlabel("granule size in the run's particles n")
    axes[3].set_ylabel(panels[0][2])
    axes[0].legend(fontsize=8)
    fig.suptitle("PBM rates under coarse-graining (classes with ≥ 3 events; bars: ±1/√events); lab drum on "
                 "revolutions 3–6, paper drum on 2–3", fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def markdown(table, fmt):
    """A markdown table (pandas' to_markdown needs tabulate, which the project does not install)."""
    def cell(v):
        return format(v, fmt) if isinstance(v, (float, np.floating)) else str(v)

    lines = ["| " + " | ".join(table.columns) + " |", "|" + " --- |" * len(table.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in table.itertuples(index=False)]
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="build/pbm-study")
    parser.add_argument("--figures", default="docs/figures")
    parser.add_argument("--progress", action="store_true")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    os.makedirs(args.figures, exist_ok=True)
    warnings.simplefilter("ignore", UserWarning)  # the runs' uneven frame spacing outside [3, 6] is known
    table, predictions = prediction_table(args.progress)
    table.to_csv(os.path.join(args.out, "prediction.csv"), index=False)
    prediction_figure(predictions, os.path.join(args.figures, "pbm_prediction.png"))
    pd.set_option("display.width", 250)
    cols = ["run", "fit_window", "start_rev", "rev", "pbm_mean_size", "dem_mean_size", "pbm_yield", "dem_yield",
            "ks_d", "ks_d_persistence", "ks_d_dem_frame_vs_window", "dem_mean_window", "dem_yield_window"]
    print(markdown(table[cols], ".3f"))
    print(f"\nlargest relative change of the primary particles in any prediction: {table.pbm_mass_error.max():.1e}\n")
    cg = cg_kernels(args.progress)
    cg.to_csv(os.path.join(args.out, "cg_kernels.csv"), index=False)
    cg_figure(cg, os.path.join(args.figures, "pbm_cg_kernels.png"))
    cols = ["run", "equiv_min", "equiv_max", "n_mean", "coalescence_per_granule_s", "n_coalescence_events",
            "selection_per_s", "n_breakage", "beta_diag_per_s", "n_diag_events"]
    print(markdown(cg[cols], ".4g"))
    print(f"\nwrote {args.out}/prediction.csv, {args.out}/cg_kernels.csv, {args.figures}/pbm_prediction.png, "
          f"{args.figures}/pbm_cg_kernels.png")


if __name__ == "__main__":
    main()
