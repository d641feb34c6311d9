"""Granule statistics and bed dynamics of our simulator beside YADE on the same drum, from the same
settled beds (the runs of ``benchmarks/yade_series.py``; never needed by the tests).

Usage: python benchmarks/yade_side_by_side.py [KEEP ...] [--window R0:R1] [--c-agg C] [--a-agg DEG]

Each folder KEEP (default benchmarks/yade_runs and its walls/ folder) holds runs named
``LABEL-g<γ>-s<seed>.h5`` (γ [N/m] of the original system): ``sim`` (ours) and ``yade`` (YADE's
converted run, on our run's settled bed), the float32 subsets that ``yade_series.py`` keeps, and
the wall experiments' runs, e.g. ``sim-f96`` (ours in YADE's 96-facet polygon,
``benchmarks/wall_runs.py``) or ``yade-seg384`` (YADE with a 384-segment cylinder). For every
run, over the steady window (default [1, 3] revolutions), per frame:

- the yield and ⟨V_g⟩/V_p under the "acting" and the "bridge" cohesion conventions (GNA at
  C_agg = 0.6, A_agg = 20°; ``granalytics.run_stats``);
- the separated wet share: wet pairs (bridge volume > 0) with a gap > 0 among all wet pairs;
- the touching coordination: particle–particle contacts with overlap per particle, 2·n_touching/N
  (``granalytics.bed_structure``);
- the kinetic energy per particle [J]: translational, m = ρ·4/3·π·r³;
- the bed angle [deg] (``granalytics.bed_flow``: the azimuth of the bed's centre of mass about the
  drum axis from the drum's lowest point, computed with our run's metadata for both codes, as the
  drum is the same);
- the wall share: the fraction of particles within 0.1 r of the cylinder (a gap to the circle of
  radius R_d below 0.1 r), and their wall slip: the mean of (v_θ − Ω·ρ)/(Ω·R_d), v_θ the
  azimuthal velocity at the centre's distance ρ from the axis (0: carried with the wall; −1: at
  rest in the lab while the wall turns).

Printed as a Markdown table, per γ and code: the mean over the seeds present of each run's
window mean ± the replica standard error (standard deviation of the run means / √n,
``granalytics.replica_steady_state``); with one seed, its window mean alone.
"""

from __future__ import annotations

import argparse
import glob
import math
import os
import re

import numpy as np
import pandas as pd

import granalytics as ga

#: metric -> column header
METRICS = {
    "yield_fraction_acting": "acting yield", "mean_volume_norm_acting": "acting ⟨V_g⟩/V_p",
    "yield_fraction_bridge": "bridge yield", "mean_volume_norm_bridge": "bridge ⟨V_g⟩/V_p",
    "separated_share": "separated wet share", "coordination": "touching coordination",
    "kinetic_energy_j": "KE per particle [J]", "bed_angle_deg": "bed angle [°]",
    "wall_share": "wall share", "wall_slip": "wall slip",
}


def dynamics(snapshot, density, drum_meta):
    """Separated wet share, touching coordination, kinetic energy per particle [J], bed angle
    [deg], wall share and wall slip of one frame (``drum_meta``: the metadata of our run, which
    names the drum)."""
    wet = snapshot.bridge_volume > 0
    separated = wet & (snapshot.gap > 0)
    mass = density * 4.0 / 3.0 * math.pi * snapshot.radius**3
    drum_radius, omega = drum_meta.sim_config["params"]["drum_radius"], drum_meta.drum_omega
    x, y = snapshot.position[:, 0], snapshot.position[:, 1]
    rho = np.hypot(x, y)
    near = drum_radius - (rho + snapshot.radius) < 0.1 * snapshot.radius
    v_theta = (x * snapshot.velocity[:, 1] - y * snapshot.velocity[:, 0]) / rho
    slip = (v_theta - omega * rho) / (omega * drum_radius)
    return {
        "wall_share": float(near.mean()),
        "wall_slip": float(slip[near].mean()) if near.any() else float("nan"),
        "separated_share": separated.sum() / max(wet.sum(), 1),
        "coordination": ga.bed_structure(snapshot).coordination,
        "kinetic_energy_j": float((0.5 * mass * (snapshot.velocity**2).sum(axis=1)).mean()),
        "bed_angle_deg": ga.bed_flow(snapshot, drum_meta)[0],
    }


def time_series(path, window, drum_meta, gna, fixed_threshold=None):
    """One row per frame of run ``path`` inside ``window`` [revolutions]: ``revolutions`` and the
    metrics of :data:`METRICS`. With ``fixed_threshold`` = G/γ (G the fixed-threshold γ, γ the
    run's original-system γ), also the yield and ⟨V_g⟩/V_p under each convention with the
    threshold C_agg·2π·G·R, the same force at every γ (columns ending ``_fixed``). A frame without
    a granule has ⟨V_g⟩/V_p = 0 (the paper's Fig 7 line is 0 below its onset)."""
    variants = [("acting", ""), ("bridge", "")]
    if fixed_threshold is not None:
        variants += [("acting", "_fixed"), ("bridge", "_fixed")]
    with ga.open_run(path) as run:
        frames = run.select(revolutions=window)
        series = None
        for cohesion, suffix in variants:
            params = dict(gna, c_agg=gna["c_agg"] * fixed_threshold) if suffix else gna
            stats = ga.run_stats(frames, cohesion=cohesion, **params)
            stats["mean_volume_norm"] = stats["mean_volume_norm"].fillna(0.0)  # no granule: 0, as below Fig 7's onset
            part = stats[["revolutions", "yield_fraction", "mean_volume_norm"]].rename(
                columns={"yield_fraction": f"yield_fraction_{cohesion}{suffix}",
                         "mean_volume_norm": f"mean_volume_norm_{cohesion}{suffix}"})
            series = part if series is None else series.merge(part, on="revolutions")
        per_frame = pd.DataFrame([dynamics(s, run.meta.density, drum_meta) for s in frames])
    return pd.concat([series.reset_index(drop=True), per_frame], axis=1)


def run_cost(path):
    """Wall-clock time [s] of the run that made ``path`` (ours: ``provenance.wall_time_s``; YADE's
    converted run: its stepping, ``provenance.yade_cost.wall_s``), None if not recorded."""
    with ga.open_run(path) as run:
        provenance = run.meta.provenance
    return provenance.get("wall_time_s", provenance.get("yade_cost", {}).get("wall_s"))


def find_runs(folders):
    """``{(γ, label): {seed: path}}`` of the runs ``LABEL-g<γ>-s<seed>.h5`` in ``folders``."""
    runs = {}
    for folder in folders:
        for path in sorted(glob.glob(os.path.join(folder, "*-g*-s*.h5"))):
            match = re.fullmatch(r"(.+)-g([0-9.e+-]+)-s(\d+)\.h5", os.path.basename(path))
            if match is None:
                print(f"skipped {path}: not a name LABEL-g<γ>-s<seed>.h5")
                continue
            runs.setdefault((float(match.group(2)), match.group(1)), {})[int(match.group(3))] = path
    return runs


def drum_of(runs):
    """The metadata of one of our runs (every case is the same drum; YADE's converted runs do not
    name its radius)."""
    for cases in runs.values():
        for path in cases.values():
            with ga.open_run(path) as run:
                if (run.meta.sim_config or {}).get("params"):
                    return run.meta
    raise SystemExit("no run of our simulator among the runs: the drum's radius is unknown")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("keep", nargs="*", default=["benchmarks/yade_runs", "benchmarks/yade_runs/walls"],
                        help="folders of the runs LABEL-g<γ>-s<seed>.h5 (default benchmarks/yade_runs and its walls/)")
    parser.add_argument("--window", default="1:3", help="steady window R0:R1 [revolutions] (default 1:3)")
    parser.add_argument("--c-agg", type=float, default=0.6, help="GNA C_agg (default 0.6)")
    parser.add_argument("--a-agg", type=float, default=20.0, help="GNA A_agg [deg] (default 20)")
    parser.add_argument("--fixed-gamma", type=float, default=0.1095,
                        help="Fig 7 also with the threshold C_agg·2π·G·R fixed at this γ [N/m] for every run "
                             "(default 0.1095, the study's base γ; 0: not)")
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    gna = {"c_agg": args.c_agg, "a_agg_deg": args.a_agg}
    runs = find_runs(args.keep)
    if not runs:
        raise SystemExit(f"{', '.join(args.keep)}: no run LABEL-g<γ>-s<seed>.h5")
    drum_meta = drum_of(runs)
    print(f"window [{window[0]:g}, {window[1]:g}] revolutions, GNA C_agg = {args.c_agg:g}, A_agg = {args.a_agg:g}°; "
          "mean over seeds ± replica s.e. (none with one seed)\n")
    print("| γ [N/m] | run | seeds | " + " | ".join(METRICS.values()) + " | wall time per run [s] |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in METRICS) + " | --- |")
    tables = {}
    for (gamma, label), cases in sorted(runs.items()):
        fixed = args.fixed_gamma / gamma if args.fixed_gamma > 0 else None
        series = [time_series(path, window, drum_meta, gna, fixed) for _, path in sorted(cases.items())]
        columns = [c for c in series[0].columns if c != "revolutions"]
        if len(series) > 1:
            table = ga.replica_steady_state(series, window=window, columns=columns)
            cells = [f"{table.loc[m, 'mean']:.4g} ± {table.loc[m, 'replica_sem']:.2g}" for m in METRICS]
        else:
            table = ga.steady_state(series[0], window=window, columns=columns)
            table["replica_sem"] = float("nan")
            cells = [f"{table.loc[m, 'mean']:.4g}" for m in METRICS]
        tables[gamma, label] = table
        cells = [c.replace("nan", "n/a") for c in cells]
        costs = [c for c in map(run_cost, cases.values()) if c is not None]
        cells.append(f"{min(costs):.0f}–{max(costs):.0f}" if len(costs) > 1 else f"{costs[0]:.0f}" if costs else "n/a")
        print(f"| {gamma:g} | {label} | {','.join(map(str, sorted(cases)))} | " + " | ".join(cells) + " |")
    print_fig7_lines(tables)


def fig7_line(gammas, means, sems):
    """Slope [per N/m] ± its error, intercept, and onset γ₁ = −intercept/slope [N/m] (None unless
    the line rises and crosses 0 above γ = 0) of ⟨V_g⟩/V_p against γ: weighted least squares with
    weights 1/s.e.² where every point has a replica s.e., else unweighted (error from the residuals)."""
    x, y, e = (np.asarray(v, dtype=float) for v in (gammas, means, sems))
    weighted = bool(np.all(np.isfinite(e)) and np.all(e > 0))
    w = 1.0 / e**2 if weighted else np.ones_like(x)
    design = np.column_stack([x, np.ones_like(x)])
    cov = np.linalg.inv(design.T @ (design * w[:, None]))
    slope, intercept = cov @ (design.T @ (w * y))
    if not weighted:  # scale by the residual variance (needs 3 or more points)
        dof = len(x) - 2
        cov = cov * (np.sum((y - design @ [slope, intercept]) ** 2) / dof if dof > 0 else np.nan)
    onset = -intercept / slope if slope > 0 and intercept < 0 else None
    return slope, float(np.sqrt(cov[0, 0])), intercept, onset


def print_fig7_lines(tables):
    """The straight line of ⟨V_g⟩/V_p against γ for every run label measured at 2 or more γ."""
    labels = sorted({label for _, label in tables})
    rows = []
    for label in labels:
        gammas = sorted(g for g, lab in tables if lab == label)
        if len(gammas) < 2:
            continue
        for convention in ("acting", "bridge", "acting_fixed", "bridge_fixed"):
            metric = f"mean_volume_norm_{convention}"
            if metric not in tables[gammas[0], label].index:
                continue
            means = [tables[g, label].loc[metric, "mean"] for g in gammas]
            sems = [tables[g, label].loc[metric, "replica_sem"] for g in gammas]
            slope, err, intercept, onset = fig7_line(gammas, means, sems)
            rows.append(f"| {label} | {convention} | {','.join(f'{g:g}' for g in gammas)} | {slope:.3g} ± {err:.2g} | "
                        f"{intercept:.3g} | {'none' if onset is None else f'{onset:.3g}'} |")
    if rows:
        print("\nFig 7: ⟨V_g⟩/V_p = slope·γ + intercept (weighted by the replica s.e. where every point has one; "
              "_fixed: the threshold C_agg·2π·G·R at the fixed γ = G of --fixed-gamma)\n")
        print("| run | convention | γ [N/m] | slope [per N/m] | intercept | onset γ₁ [N/m] |")
        print("| --- | --- | --- | --- | --- | --- |")
        print("\n".join(rows))

if __name__ == "__main__":
    main()
