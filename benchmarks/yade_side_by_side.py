"""Granule statistics and bed dynamics of our simulator beside YADE on the same drum, from the same
settled beds (the runs of ``benchmarks/yade_series.py``; never needed by the tests).

Usage: python benchmarks/yade_side_by_side.py [KEEP] [--window R0:R1] [--c-agg C] [--a-agg DEG]

KEEP (default benchmarks/yade_runs) holds, for every case TAG = g<γ>-s<seed> (γ [N/m] of the
original system), our run ``sim-TAG.h5`` and YADE's converted run ``yade-TAG.h5`` (the float32
subsets that ``yade_series.py`` keeps). For every run, over the steady window (default [1, 3]
revolutions), per frame:

- the yield and ⟨V_g⟩/V_p under the "acting" and the "bridge" cohesion conventions (GNA at
  C_agg = 0.6, A_agg = 20°; ``granalytics.run_stats``);
- the separated wet share: wet pairs (bridge volume > 0) with a gap > 0 among all wet pairs;
- the touching coordination: particle–particle contacts with overlap per particle, 2·n_touching/N
  (``granalytics.bed_structure``);
- the kinetic energy per particle [J]: translational, m = ρ·4/3·π·r³;
- the bed angle [deg] (``granalytics.bed_flow``: the azimuth of the bed's centre of mass about the
  drum axis from the drum's lowest point, computed with our run's metadata for both codes, as the
  drum is the same).

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

import pandas as pd

import granalytics as ga

#: metric -> column header
METRICS = {
    "yield_fraction_acting": "acting yield", "mean_volume_norm_acting": "acting ⟨V_g⟩/V_p",
    "yield_fraction_bridge": "bridge yield", "mean_volume_norm_bridge": "bridge ⟨V_g⟩/V_p",
    "separated_share": "separated wet share", "coordination": "touching coordination",
    "kinetic_energy_j": "KE per particle [J]", "bed_angle_deg": "bed angle [°]",
}


def dynamics(snapshot, density, drum_meta):
    """Separated wet share, touching coordination, kinetic energy per particle [J] and bed angle
    [deg] of one frame (``drum_meta``: the metadata of our run, which names the drum)."""
    wet = snapshot.bridge_volume > 0
    separated = wet & (snapshot.gap > 0)
    mass = density * 4.0 / 3.0 * math.pi * snapshot.radius**3
    return {
        "separated_share": separated.sum() / max(wet.sum(), 1),
        "coordination": ga.bed_structure(snapshot).coordination,
        "kinetic_energy_j": float((0.5 * mass * (snapshot.velocity**2).sum(axis=1)).mean()),
        "bed_angle_deg": ga.bed_flow(snapshot, drum_meta)[0],
    }


def time_series(path, window, drum_meta, gna):
    """One row per frame of run ``path`` inside ``window`` [revolutions]: ``revolutions`` and the
    metrics of :data:`METRICS`."""
    with ga.open_run(path) as run:
        frames = run.select(revolutions=window)
        series = None
        for cohesion in ("acting", "bridge"):
            stats = ga.run_stats(frames, cohesion=cohesion, **gna)
            part = stats[["revolutions", "yield_fraction", "mean_volume_norm"]].rename(
                columns={"yield_fraction": f"yield_fraction_{cohesion}",
                         "mean_volume_norm": f"mean_volume_norm_{cohesion}"})
            series = part if series is None else series.merge(part, on="revolutions")
        per_frame = pd.DataFrame([dynamics(s, run.meta.density, drum_meta) for s in frames])
    return pd.concat([series.reset_index(drop=True), per_frame], axis=1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("keep", nargs="?", default="benchmarks/yade_runs",
                        help="folder of the pairs sim-TAG.h5, yade-TAG.h5 (default benchmarks/yade_runs)")
    parser.add_argument("--window", default="1:3", help="steady window R0:R1 [revolutions] (default 1:3)")
    parser.add_argument("--c-agg", type=float, default=0.6, help="GNA C_agg (default 0.6)")
    parser.add_argument("--a-agg", type=float, default=20.0, help="GNA A_agg [deg] (default 20)")
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    gna = {"c_agg": args.c_agg, "a_agg_deg": args.a_agg}
    series = {}  # (γ, code) -> [time series per seed]
    seeds = {}
    for yade in sorted(glob.glob(os.path.join(args.keep, "yade-g*-s*.h5"))):
        tag = os.path.basename(yade)[len("yade-"):-len(".h5")]
        match = re.fullmatch(r"g([0-9.e+-]+)-s(\d+)", tag)
        ours = os.path.join(args.keep, f"sim-{tag}.h5")
        if match is None or not os.path.exists(ours):
            print(f"skipped {yade}: " + ("not a case name" if match is None else f"no {ours}"))
            continue
        gamma = float(match.group(1))
        seeds.setdefault(gamma, []).append(int(match.group(2)))
        with ga.open_run(ours) as run:
            drum_meta = run.meta
        for code, path in (("sim", ours), ("yade", yade)):
            series.setdefault((gamma, code), []).append(time_series(path, window, drum_meta, gna))
    if not series:
        raise SystemExit(f"{args.keep}: no pair sim-TAG.h5, yade-TAG.h5")
    print(f"window [{window[0]:g}, {window[1]:g}] revolutions, GNA C_agg = {args.c_agg:g}, A_agg = {args.a_agg:g}°; "
          "mean over seeds ± replica s.e. (none with one seed)\n")
    print("| γ [N/m] | code | seeds | " + " | ".join(METRICS.values()) + " |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in METRICS) + " |")
    for (gamma, code), runs in sorted(series.items()):
        if len(runs) > 1:
            table = ga.replica_steady_state(runs, window=window, columns=list(METRICS))
            cells = [f"{table.loc[m, 'mean']:.4g} ± {table.loc[m, 'replica_sem']:.2g}" for m in METRICS]
        else:
            table = ga.steady_state(runs[0], window=window, columns=list(METRICS))
            cells = [f"{table.loc[m, 'mean']:.4g}" for m in METRICS]
        cells = [c.replace("nan", "n/a") for c in cells]
        print(f"| {gamma:g} | {code} | {','.join(map(str, sorted(seeds[gamma])))} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
