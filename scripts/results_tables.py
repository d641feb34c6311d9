"""Print the tables of docs/results.md from the bundled datasets (Markdown on stdout).

Usage: python scripts/results_tables.py [--figures DIR] [--parts runs,sweeps] [--replica-sweep DIR]
       [--gamma-runs RUN ...]

Every number in docs/results.md comes from this script: steady-state yield, ⟨V_g⟩/V_p and N_g/N
of every bundled run under both cohesion conventions (GNA, C_agg = 0.6, A_agg = 20°), the CG
comparisons (deviation from the finest run, Kolmogorov–Smirnov distance of the size
distributions) and the measured speed-ups, the granule kinetics of the lab runs (tracked events
per particle per revolution), the replica sets (replica standard error beside the block s.e.m.,
and the CG deviations with replica errors), and the γ × Ω study of every bundled sweep (steady
state per point, the growth-law fit beside the paper's β and γ₁, the surrogate's leave-one-out
error). With ``--figures DIR`` (docs/figures for the results page) it also writes, as PNG, the CG
figures (the paper's Figs 3–6) of the lab and paper-drum comparisons into DIR/lab-drum and
DIR/paper-drum (Fig 5 also in original-particle equivalents, ``fig5_size_distribution_original``),
the CG deviation heatmaps over the threshold grid and the Fig 7 analogue of each sweep into DIR.
``--replica-sweep`` and ``--gamma-runs`` add runs that are not bundled (docs/results.md says how
they were made).
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

import granalytics as ga
from granalytics.datasets import DATASETS, REPLICAS, SWEEPS, dataset_path, replica_paths, sweep_path

C_AGG, A_AGG = 0.6, 20.0
#: steady-state window [revolutions] of each run: [3, 6] for 6-revolution runs (paper Fig 5),
#: [2, 3] for the 3-revolution ones (growth vanishes after two revolutions, paper Fig 6)
WINDOWS = {"lab-cg1": (3, 6), "lab-cg2": (3, 6), "lab-cg3": (3, 6), "paper-cg2": (2, 3), "paper-cg3": (3, 6)}
CG_SETS = {"lab drum": ["lab-cg1", "lab-cg2", "lab-cg3"], "paper drum": ["paper-cg2", "paper-cg3"]}
#: the window common to every run of a comparison: [3, 6] on the lab drum (every lab run has 6
#: revolutions), [2, 3] on the paper's drum (paper-cg2 has 3)
CG_WINDOWS = {"lab drum": (3, 6), "paper drum": (2, 3)}
CG_WINDOW = CG_WINDOWS["lab drum"]
#: the bundled runs that are not replicas of another one (the replicas are in the replica tables)
MAIN_RUNS = [n for n in DATASETS if not any(n in names[1:] for names in REPLICAS.values())]


def pm(mean, sem, digits):
    return f"{mean:.{digits}f} ± {sem:.{digits}f}"


def bed_table():
    """Is every bundled run a 3-D bed? The settled bed (recorded by the simulator) and the flowing
    bed (mean over the steady window's frames)."""
    print("| dataset | settled: crossing | settled: ⟨n_z²⟩ | settled: coordination | settled: solid fraction "
          "| flowing: crossing | flowing: ⟨\\|v_z\\|⟩/⟨\\|v_xy\\|⟩ | flowing: coordination |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in DATASETS:
        with ga.open_run(dataset_path(name)) as run:
            settled = run.meta.provenance.get("settled_bed") or {}
            base = next((b for b, names in REPLICAS.items() if name in names), name)
            frames = run.select(revolutions=WINDOWS[base])
            beds = [ga.bed_structure(s) for s in frames]
        cells = [f"{settled[k]:.3f}" if k in settled else "—"
                 for k in ("crossing_fraction", "axial_fabric", "coordination", "solid_fraction")]
        flowing = [sum(getattr(b, k) for b in beds) / len(beds)
                   for k in ("crossing_fraction", "axial_speed_ratio", "coordination")]
        print(f"| {name} | {' | '.join(cells)} | {flowing[0]:.3f} | {flowing[1]:.3f} | {flowing[2]:.2f} |")


def gamma_check_table(paths, window=(2, 3)):
    """The paper's drum at CG3 at several γ (runs not bundled: build/runs/paper-cg3-gamma*.h5 and the
    bundled paper-cg3 at γ = 0.1095 N/m), beside the paper's law β(γ − γ₁)."""
    from granalytics.analysis.study import PAPER_BETA, PAPER_GAMMA_1

    print(f"\n**paper drum, CG3, γ check** (window {window[0]}–{window[1]} revolutions; γ of the original system)\n")
    print("| γ [N/m] | run | cohesion | yield | ⟨V_g⟩/V_p | N_g/N | paper law ⟨V_g⟩/V_p |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    points = {cohesion: [] for cohesion in ga.COHESION_CONVENTIONS}
    for path in paths:
        with ga.open_run(path) as run:
            gamma = run.meta.sim_config["original"]["surface_tension"]
            for cohesion in ga.COHESION_CONVENTIONS:
                ts = ga.run_stats(run.select(revolutions=(0, window[1] + 0.01)), c_agg=C_AGG, a_agg_deg=A_AGG,
                                  cohesion=cohesion)
                s = ga.steady_state(ts, window=window)
                law = PAPER_BETA * max(0.0, gamma - PAPER_GAMMA_1)
                print(f"| {gamma:g} | {os.path.basename(path)} | {cohesion} | "
                      f"{pm(s.loc['yield_fraction', 'mean'], s.loc['yield_fraction', 'sem'], 3)} | "
                      f"{pm(s.loc['mean_volume_norm', 'mean'], s.loc['mean_volume_norm', 'sem'], 2)} | "
                      f"{pm(s.loc['n_granules_norm', 'mean'], s.loc['n_granules_norm', 'sem'], 4)} | {law:.2f} |")
                points[cohesion].append((gamma, s.loc["mean_volume_norm", "mean"], s.loc["mean_volume_norm", "sem"]))
    for cohesion, rows in points.items():
        if len(rows) >= 3:
            growth_fits(*(np.array(column) for column in zip(*sorted(rows))), cohesion)


def growth_fits(gamma, mean_volume_norm, sem, cohesion):
    """Print the two fits of ⟨V_g⟩/V_p against γ [N/m]: the paper's hinge β(γ − γ₁), weighted by
    1/sem² (``ga.fit_granule_growth``; returned, None where it fails), and the unweighted straight
    line through every point (slope, its 95 % t-interval, p, and where the line is zero, γ₀)."""
    from scipy.stats import linregress
    from scipy.stats import t as student_t

    try:
        fit = ga.fit_granule_growth(gamma, mean_volume_norm, sem)
        print(f"\ngrowth fit ({cohesion}, weighted by 1/sem²): {fit.summary()}")
    except ga.GranalyticsError as exc:
        fit = None
        print(f"\ngrowth fit ({cohesion}): none: {exc}")
    slope = linregress(gamma, mean_volume_norm)
    half = student_t.ppf(0.975, len(gamma) - 2) * slope.stderr
    print(f"straight line through all points ({cohesion}, unweighted): d⟨V_g⟩/V_p / dγ = {slope.slope:.2f} ± "
          f"{slope.stderr:.2f} [{slope.slope - half:.2f}, {slope.slope + half:.2f}] per N/m (95 %; the paper's "
          f"β ≈ 70), p = {slope.pvalue:.2g}, zero at γ₀ = "
          f"{-slope.intercept / slope.slope if slope.slope else math.nan:.2g} N/m")
    return fit


def cg_threshold_table(figures=None):
    """The lab CG comparison at every (C_agg, A_agg) of a grid (acting cohesion): the median and
    largest |deviation| from lab-cg1 of each headline statistic over the grid."""
    from granalytics.analysis.metrics import BY_FIGURE, METRICS
    from granalytics.report.figures import cg_threshold_figures

    names = CG_SETS["lab drum"]
    c_agg, a_agg = [round(0.2 + 0.1 * k, 2) for k in range(8)], [10.0, 20.0, 45.0]
    table = ga.compare_cg_thresholds([dataset_path(n) for n in names], c_agg, a_agg, labels=names,
                                     window=CG_WINDOW).table
    print(f"\n**CG deviation at every threshold pair** (lab drum, acting cohesion, window {CG_WINDOW[0]}–"
          f"{CG_WINDOW[1]}; C_agg = 0.2 … 0.9, A_agg = 10°, 20°, 45°; |deviation| from lab-cg1 over the "
          f"pairs of the {len(c_agg) * len(a_agg)} where both runs have granules)\n")
    print("| run | statistic | pairs | median \\|dev.\\| | largest \\|dev.\\| (at C_agg, A_agg) | at the paper's 0.6, 20° |")
    print("| --- | --- | --- | --- | --- | --- |")
    for run in names[1:]:
        part = table[table.run == run]
        for metric in BY_FIGURE:
            dev = part[f"{metric}_rel_dev"].abs()
            if not dev.notna().any():
                continue
            worst = part.loc[dev.idxmax()]
            paper = part[(part.c_agg == 0.6) & (part.a_agg_deg == 20.0)][f"{metric}_rel_dev"].iloc[0]
            print(f"| {run} | {METRICS[metric].label} | {dev.notna().sum()} | {100 * dev.median():.0f} % | {100 * dev.max():.0f} % "
                  f"({worst.c_agg:g}, {worst.a_agg_deg:g}°) | {100 * paper:+.0f} % |")
    if figures:
        import matplotlib.pyplot as plt

        for name, fig in cg_threshold_figures(table).items():
            fig.savefig(os.path.join(figures, f"{name}.png"), dpi=120)
            plt.close(fig)


def replica_table():
    """The bundled replica sets (seeds 0, 1, 2): the steady state over replicas with the replica
    standard error beside the block s.e.m., then the lab CG comparison with replica groups."""
    print(f"\n**replicas** (seeds 0, 1, 2; window {CG_WINDOW[0]}–{CG_WINDOW[1]} revolutions, acting cohesion)\n")
    print("| run | replicas | yield | replica s.e. | block s.e.m. | ⟨V_g⟩/V_p | replica s.e. | block s.e.m. "
          "| N_g/N | replica s.e. | block s.e.m. |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for base in REPLICAS:
        series = []
        for path in replica_paths(base):
            with ga.open_run(path) as run:
                series.append(ga.run_stats(run, c_agg=C_AGG, a_agg_deg=A_AGG))
        r = ga.replica_steady_state(series, window=CG_WINDOW)
        cells = [f"{r.loc[m, 'mean']:.{d}f} | {r.loc[m, 'replica_sem']:.{d}f} | {r.loc[m, 'block_sem']:.{d}f}"
                 for m, d in (("yield_fraction", 3), ("mean_volume_norm", 2), ("n_granules_norm", 4))]
        print(f"| {base} | {int(r['n_replicas'].iloc[0])} | {' | '.join(cells)} |")
    names = CG_SETS["lab drum"]
    groups = [replica_paths(n) if n in REPLICAS else dataset_path(n) for n in names]
    print("\n**lab drum, CG deviations with replicas** (lab-cg1: one run; lab-cg2, lab-cg3: three seeds each; "
          "deviation ± its standard error from the larger of the CG run's replica s.e. and block s.e.m., and the "
          "block s.e.m. of lab-cg1)\n")
    print("| run | cohesion | yield (dev.) | ⟨V_g⟩/V_p (dev.) | N_g/N (dev.) | KS D |")
    print("| --- | --- | --- | --- | --- | --- |")
    for cohesion in ga.COHESION_CONVENTIONS:
        cmp = ga.compare_cg(groups, labels=names, window=CG_WINDOW, c_agg=C_AGG, a_agg_deg=A_AGG, cohesion=cohesion)
        for row in cmp.table.itertuples():
            cells = []
            for m, d in (("yield_fraction", 3), ("mean_volume_norm", 2), ("n_granules_norm", 4)):
                mean, rsem, dev, dse = (getattr(row, f"{m}_{x}") for x in ("mean", "replica_sem", "rel_dev", "rel_dev_se"))
                err = f" ± {rsem:.{d}f}" if row.n_replicas > 1 else ""
                cells.append(f"{mean:.{d}f}{err} ({dev:+.0%}" + (f" ± {dse:.0%})" if row.run != names[0] else ")"))
            print(f"| {row.run} | {cohesion} | {' | '.join(cells)} | {row.ks_distance:.3f} |")


def steady_table():
    print("| dataset | particles (α) | window [rev] | cohesion | yield | ⟨V_g⟩/V_p | N_g/N |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in MAIN_RUNS:
        window = WINDOWS[name]
        with ga.open_run(dataset_path(name)) as run:
            for cohesion in ga.COHESION_CONVENTIONS:
                ts = ga.run_stats(run, c_agg=C_AGG, a_agg_deg=A_AGG, cohesion=cohesion)
                s = ga.steady_state(ts, window=window)
                print(f"| {name} | {run.meta.n_particles} ({run.meta.alpha:g}) | {window[0]}–{window[1]} | {cohesion} | "
                      f"{pm(s.loc['yield_fraction', 'mean'], s.loc['yield_fraction', 'sem'], 3)} | "
                      f"{pm(s.loc['mean_volume_norm', 'mean'], s.loc['mean_volume_norm', 'sem'], 2)} | "
                      f"{pm(s.loc['n_granules_norm', 'mean'], s.loc['n_granules_norm', 'sem'], 4)} |")


def cg_tables(figures=None):
    for title, names in CG_SETS.items():
        window = CG_WINDOWS[title]
        print(f"\n**{title}** ({', '.join(names)}; window {window[0]}–{window[1]} revolutions; "
              f"deviation from {names[0]}; ± the block s.e.m.)\n")
        print("| run | cohesion | yield (dev.) | ⟨V_g⟩/V_p (dev.) | N_g/N (dev.) | KS D | W1(log10 n) |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for cohesion in ga.COHESION_CONVENTIONS:
            cmp = ga.compare_cg([dataset_path(n) for n in names], labels=names, window=window,
                                c_agg=C_AGG, a_agg_deg=A_AGG, cohesion=cohesion)
            for row in cmp.table.itertuples():
                cells = [f"{pm(getattr(row, f'{m}_mean'), getattr(row, f'{m}_sem'), d)} "
                         f"({getattr(row, f'{m}_rel_dev'):+.0%})"
                         for m, d in (("yield_fraction", 3), ("mean_volume_norm", 2), ("n_granules_norm", 4))]
                print(f"| {row.run} | {cohesion} | {' | '.join(cells)} | {row.ks_distance:.3f} | {row.w1_log10_size:.3f} |")
            if figures and cohesion == "acting":
                import matplotlib.pyplot as plt

                from granalytics.report.figures import cg_figures

                folder = os.path.join(figures, title.replace(" ", "-"))
                os.makedirs(folder, exist_ok=True)
                drawn, original = cg_figures(cmp), cg_figures(cmp, size_unit="original")
                drawn["fig5_size_distribution_original"] = original.pop("fig5_size_distribution")
                for fig in original.values():  # Figs 3, 4, 6 do not depend on the size unit
                    plt.close(fig)
                for key, fig in drawn.items():  # compare-cg's figures, without its tables
                    fig.savefig(os.path.join(folder, f"{key}.png"), dpi=120)
                    plt.close(fig)
        threads = {}
        for n in names:
            with ga.open_run(dataset_path(n)) as run:
                threads[n] = run.meta.provenance.get("threads")
        print(f"\nSpeed-ups ({title}, simulator wall time per simulated second, from the runs' metadata; "
              f"fair only between runs on the same number of threads):\n")
        print("| run | particles | threads | wall s per simulated s | speed-up | paper |")
        print("| --- | --- | --- | --- | --- | --- |")
        for row in cmp.table.itertuples():
            print(f"| {row.run} | {row.n_particles} | {threads[row.run]} | {row.wall_time_per_simulated_s:.1f} | "
                  f"{row.speedup:.1f}× | {row.paper_speedup:.1f}× |")


KINETICS_RUNS, KINETICS_WINDOW = ["lab-cg1", "lab-cg2", "lab-cg3"], (3, 6)


def kinetics_table():
    """Tracked granule events of the lab runs (acting cohesion), per particle per revolution."""
    kinds = ("birth", "death", "coalescence", "breakage")
    revolutions = KINETICS_WINDOW[1] - KINETICS_WINDOW[0]
    print(f"\n**granule kinetics** (window {KINETICS_WINDOW[0]}–{KINETICS_WINDOW[1]} revolutions; events per "
          f"particle per revolution, event counts in brackets)\n")
    print("| run | particles | " + " | ".join(f"{k}s" for k in kinds) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in kinds) + " |")
    for name in KINETICS_RUNS:
        with ga.open_run(dataset_path(name)) as run:
            counts = ga.track_run(run, window=KINETICS_WINDOW, c_agg=C_AGG, a_agg_deg=A_AGG).event_counts()
            n = run.meta.n_particles
        cells = " | ".join(f"{counts[k] / revolutions / n:.3g} ({counts[k]})" for k in kinds)
        print(f"| {name} | {n} | {cells} |")


SWEEP_WINDOW = (3, 6)


def sweep_tables(figures=None):
    import matplotlib.pyplot as plt

    from granalytics.report.figures import growth_figure

    for name in SWEEPS:
        table = ga.study_table(sweep_path(name), window=SWEEP_WINDOW, c_agg=C_AGG, a_agg_deg=A_AGG,
                               cohesion=ga.COHESION_CONVENTIONS)
        print(f"\n**sweep {name}** (window {SWEEP_WINDOW[0]}–{SWEEP_WINDOW[1]} revolutions; γ of the original system)\n")
        print("| γ [N/m] | Ω [rad/s] | cohesion | yield | ⟨V_g⟩/V_p | N_g/N |")
        print("| --- | --- | --- | --- | --- | --- |")
        for row in table.sort_values(["cohesion", "omega", "gamma"]).itertuples():
            print(f"| {row.gamma:g} | {row.omega:g} | {row.cohesion} | {pm(row.yield_fraction_mean, row.yield_fraction_sem, 3)} | "
                  f"{pm(row.mean_volume_norm_mean, row.mean_volume_norm_sem, 2)} | "
                  f"{pm(row.n_granules_norm_mean, row.n_granules_norm_sem, 4)} |")
        for cohesion in ga.COHESION_CONVENTIONS:
            rows = table[table.cohesion == cohesion]
            fit = growth_fits(rows.gamma, rows.mean_volume_norm_mean, rows.mean_volume_norm_sem, cohesion)
            surrogate = ga.fit_surrogate(table, inputs=("gamma", "omega"), cohesion=cohesion)
            print(f"\nsurrogate ({cohesion}), leave-one-out error:\n")
            loo = surrogate.loo
            print("| output | LOO RMSE | LOO MAE | spread of the output (std) | points |")
            print("| --- | --- | --- | --- | --- |")
            for output, r in loo.iterrows():
                print(f"| {output} | {r.rmse:.4g} | {r.mae:.4g} | {r.output_std:.4g} | {int(r.n_points)} |")
            if figures:
                fig = growth_figure(table, fit=fit, cohesion=cohesion)
                fig.savefig(os.path.join(figures, f"fig7-{name}-{cohesion}.png"), dpi=120)
                plt.close(fig)


def replica_sweep_table(folder, figures=None):
    """The Ω = 2 rad/s row of gamma-omega-lab-cg3 (seed 0, bundled) with its replicas at seeds 1
    and 2 (``folder``, made by ``python -m sim sweep datasets/sweeps/gamma-lab-cg3-replicas.toml``,
    not bundled): the replica s.e. of each Fig 7 point beside its block s.e.m., and the growth
    fit weighted by the replica errors."""
    table = ga.study_table([sweep_path("gamma-omega-lab-cg3"), folder], window=SWEEP_WINDOW, c_agg=C_AGG,
                           a_agg_deg=A_AGG, cohesion=ga.COHESION_CONVENTIONS, replicas="seed")
    table = table[(table.omega == 2.0) & (table.n_replicas > 1)].sort_values(["cohesion", "gamma"])
    print(f"\n**Fig 7 points with replicas** (lab drum, CG3, Ω = 2 rad/s, seeds 0, 1, 2; window "
          f"{SWEEP_WINDOW[0]}–{SWEEP_WINDOW[1]} revolutions)\n")
    print("| γ [N/m] | cohesion | yield | replica s.e. | block s.e.m. | ⟨V_g⟩/V_p | replica s.e. | block s.e.m. |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in table.itertuples():
        print(f"| {row.gamma:g} | {row.cohesion} | {row.yield_fraction_mean:.3f} | {row.yield_fraction_replica_sem:.3f} | "
              f"{row.yield_fraction_sem:.3f} | {row.mean_volume_norm_mean:.2f} | {row.mean_volume_norm_replica_sem:.2f} | "
              f"{row.mean_volume_norm_sem:.2f} |")
    for cohesion in ga.COHESION_CONVENTIONS:
        part = table[table.cohesion == cohesion]
        ratio = (part.mean_volume_norm_replica_sem / part.mean_volume_norm_sem).median()
        try:
            fit = ga.fit_granule_growth(part.gamma, part.mean_volume_norm_mean, part.mean_volume_norm_replica_sem)
            summary = fit.summary()
        except ga.GranalyticsError as exc:
            fit, summary = None, f"none: {exc}"
        print(f"\n{cohesion}: median replica s.e. / block s.e.m. of ⟨V_g⟩/V_p = {ratio:.2f}; growth fit weighted by "
              f"the replica errors: {summary}")
        if figures:
            import matplotlib.pyplot as plt

            from granalytics.report.figures import growth_figure

            fig = growth_figure(part, fit=fit, cohesion=cohesion)
            fig.savefig(os.path.join(figures, f"fig7-lab-cg3-replicas-{cohesion}.png"), dpi=120)
            plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figures", metavar="DIR",
                        help="folder for the figures (PNG; docs/figures for the results page)")
    parser.add_argument("--parts", default="runs,sweeps", help="which tables: runs, sweeps or both (default)")
    parser.add_argument("--replica-sweep", metavar="DIR",
                        help="the replicas of the CG3 sweep's Ω = 2 row (not bundled), e.g. build/sweeps/gamma-lab-cg3-replicas")
    parser.add_argument("--gamma-runs", nargs="*", default=[],
                        help="paper-cg3 runs at other γ (not bundled) for the γ check, e.g. build/runs/paper-cg3-gamma*.h5")
    args = parser.parse_args()
    if args.figures:
        os.makedirs(args.figures, exist_ok=True)
    parts = set(args.parts.split(","))
    if "runs" in parts:
        bed_table()
        steady_table()
        cg_tables(args.figures)
        cg_threshold_table(args.figures)
        kinetics_table()
        replica_table()
    if "sweeps" in parts:
        sweep_tables(args.figures)
    if args.replica_sweep:
        replica_sweep_table(args.replica_sweep, args.figures)
    if args.gamma_runs:
        def gamma(path):
            with ga.open_run(path) as run:
                return run.meta.surface_tension

        gamma_check_table(sorted([*args.gamma_runs, str(dataset_path("paper-cg3"))], key=gamma))


if __name__ == "__main__":
    main()
