"""Granule statistics and bed dynamics of our simulator beside YADE on the same drum, from the same
settled beds (the runs of ``benchmarks/yade_same_drum.py``; never needed by the tests).

Usage: python benchmarks/yade_side_by_side.py [FOLDER] [--window R0:R1]

FOLDER (default build/yade) holds, for every case TAG = g<γ>-s<seed>, our run ``sim-TAG.h5`` and
YADE's converted run ``TAG/yade.h5``. For every case both codes get, over the steady window
(default [3, 6] revolutions): the yield, ⟨V_g⟩/V_p and N_g/N under the acting and the bridge
conventions (GNA at the paper's thresholds), the separated share of interactions (wet pairs with a
gap > 0 among all wet pairs), the median and 90th percentile of gap/R* of the separated wet pairs
(R* = R_i R_j/(R_i + R_j)), the coordination (touching particle contacts per particle), the mean
kinetic energy per particle [J] (translational, m = ρ 4/3 π r³) and the bed angle [deg]: the
angle at the drum axis between straight down and the bed's centre of mass (it grows with the
dynamic angle of repose and does not depend on where the baffles lift single particles). Printed per γ as mean ± replica standard error over the seeds present (the block s.e.m.
of one run where there is one seed).
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


def dynamics(snapshot, density, gravity):
    """Per-frame dynamics: separated share, gap/R* quantiles, coordination, kinetic energy, bed angle."""
    wet = snapshot.bridge_volume > 0
    separated = wet & (snapshot.gap > 0)
    r_i, r_j = snapshot.radius[snapshot.contact_i], snapshot.radius[snapshot.contact_j]
    gap_r = snapshot.gap[separated] / (r_i * r_j / (r_i + r_j))[separated]
    mass = density * 4.0 / 3.0 * math.pi * snapshot.radius**3
    com = (mass[:, None] * snapshot.position).sum(axis=0) / mass.sum()  # the drum axis is z at x = y = 0
    down = np.asarray(gravity, dtype=float) / np.linalg.norm(gravity)
    across = np.array([-down[1], down[0], 0.0])  # perpendicular to gravity in the x-y plane
    return {
        "separated_share": separated.sum() / max(wet.sum(), 1),
        "gap_r_median": float(np.median(gap_r)) if gap_r.size else math.nan,
        "gap_r_p90": float(np.quantile(gap_r, 0.9)) if gap_r.size else math.nan,
        "coordination": ga.bed_structure(snapshot).coordination,
        "kinetic_energy_j": float((0.5 * mass * (snapshot.velocity**2).sum(axis=1)).mean()),
        "bed_angle_deg": abs(math.degrees(math.atan2(float(com @ across), float(com @ down)))),
    }


def case_row(path, window, gravity):
    """Steady means of one run: granule statistics under both conventions and the dynamics
    (``gravity`` [m/s²]: our run's; a converted YADE run holds none of its own)."""
    row = {}
    with ga.open_run(path) as run:
        frames = run.select(revolutions=window)
        for cohesion in ("acting", "bridge"):
            series = ga.run_stats(frames, cohesion=cohesion)
            for metric in ("yield_fraction", "mean_volume_norm", "n_granules_norm"):
                row[f"{metric}_{cohesion}"] = float(series[metric].mean())
        per_frame = pd.DataFrame([dynamics(s, run.meta.density, gravity) for s in frames])
        row.update(per_frame.mean().to_dict())
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default="build/yade")
    parser.add_argument("--window", default="3:6", help="steady window R0:R1 [revolutions] (default 3:6)")
    args = parser.parse_args()
    window = tuple(float(x) for x in args.window.split(":"))
    rows = []
    for yade in sorted(glob.glob(os.path.join(args.folder, "g*-s*", "yade.h5"))):
        tag = os.path.basename(os.path.dirname(yade))
        gamma, seed = re.fullmatch(r"g([0-9.e-]+)-s(\d+)", tag).groups()
        ours = os.path.join(args.folder, f"sim-{tag}.h5")
        with ga.open_run(ours) as run:
            gravity = run.meta.gravity
        for code, path in (("sim", ours), ("yade", yade)):
            rows.append({"gamma": float(gamma), "seed": int(seed), "code": code, **case_row(path, window, gravity)})
    if not rows:
        raise SystemExit(f"{args.folder}: no case with a converted YADE run (TAG/yade.h5)")
    table = pd.DataFrame(rows)
    metrics = [c for c in table.columns if c not in ("gamma", "seed", "code")]
    grouped = table.groupby(["gamma", "code"])[metrics]
    mean, n = grouped.mean(), grouped.size()
    err = grouped.std(ddof=1).div(np.sqrt(n), axis=0)
    print(f"window [{window[0]:g}, {window[1]:g}] revolutions; mean ± replica s.e. over seeds (n = seeds; "
          "no error with one seed)\n")
    print("| γ [N/m] | code | n | " + " | ".join(metrics) + " |")
    print("| --- | --- | --- | " + " | ".join("---" for _ in metrics) + " |")
    for key in mean.index:
        cells = [f"{mean.loc[key, m]:.4g}" + (f" ± {err.loc[key, m]:.2g}" if n[key] > 1 else "") for m in metrics]
        print(f"| {key[0]:g} | {key[1]} | {n[key]} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
