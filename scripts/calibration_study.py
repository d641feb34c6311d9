"""The numbers and figures of docs/calibration.md: the example measured file, the recovery table,
the CG-transfer table and the two figures.

    python scripts/calibration_study.py [--write-example] [--figures]

Each "measured" distribution is made from a bundled run at known thresholds (the mean over
revolutions [3, 6]) with a stated normal error on its cumulative mass fraction passing.
"""

import argparse
import pathlib
import time

import numpy as np

import granalytics as ga
from granalytics.analysis.calibration import grid_measurement

ROOT = pathlib.Path(__file__).resolve().parents[1]
DATA = ROOT / "datasets"
#: sieve classes [m]: a √2 series of apertures from 1.0 to 11.2 mm, the pan below and the top above
EDGES = np.r_[0.0, 1e-3 * np.array([1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0, 11.2]), np.inf]
C_GRID = np.linspace(0.2, 0.9, 15)
A_GRID = np.linspace(5, 60, 12)
WINDOW = (3, 6)


def grid_of(name):
    with ga.open_run(DATA / f"{name}.h5") as run:
        return ga.size_class_grid(run.select(revolutions=WINDOW), EDGES, C_GRID, A_GRID)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write-example", action="store_true", help="(re)write datasets/sieve/example-sieve.csv")
    parser.add_argument("--figures", action="store_true", help="write docs/figures/calibration_*.png")
    args = parser.parse_args()
    t = time.perf_counter()
    cg1 = grid_of("lab-cg1")
    print(f"lab-cg1 grid of {C_GRID.size} x {A_GRID.size} over {cg1.volumes.shape[0]} frames: "
          f"{time.perf_counter() - t:.1f} s")
    if args.write_example:
        m = grid_measurement(cg1, 0.45, 30.0, noise=0.01, seed=7)
        path = DATA / "sieve" / "example-sieve.csv"
        table = m.table()[["lower_m", "upper_m", "mass_fraction"]]
        table["sigma"] = 0.01
        with open(path, "w") as handle:
            handle.write("# example sieve analysis (classes form): made from datasets/lab-cg1.h5 at C_agg = 0.45, A_agg = 30 deg,\n"
                         "# revolutions [3, 6], volume-equivalent diameter, with a normal error of 0.01 on the cumulative\n"
                         "# mass fraction passing (scripts/calibration_study.py --write-example); sizes in metres\n")
            table.to_csv(handle, index=False, float_format="%.6g")
        print(f"wrote {path}")

    print("\nrecovery (lab-cg1, revolutions [3, 6], grid C_agg 0.2:0.9:15 x A_agg 5:60:12, measured error = noise)")
    print("| true C_agg, A_agg | noise | recovered | steps off (C, A) | truth in region | 95 % region (bootstrap) | C_agg | A_agg | chi2/dof |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for (c, a, noise, seed) in ((0.45, 30.0, 0.01, 1), (0.6, 20.0, 0.02, 2), (0.3, 45.0, 0.01, 3)):
        m = grid_measurement(cg1, c, a, noise=noise, seed=seed)
        cal = ga.calibrate_thresholds(cg1, m, C_GRID, A_GRID)
        r = cal.region
        truth = bool(((np.isclose(r.c_agg, c)) & (np.isclose(r.a_agg_deg, a))).any())
        steps = (round((cal.best["c_agg"] - c) / 0.05), round((cal.best["a_agg_deg"] - a) / 5))
        print(f"| {c:g}, {a:g}° | {noise:g} | {cal.best['c_agg']:g}, {cal.best['a_agg_deg']:g}° | {steps[0]:+d}, {steps[1]:+d} | "
              f"{'yes' if truth else 'no'} | {len(r)} points, C_agg "
              f"[{r.c_agg.min():g}, {r.c_agg.max():g}], A_agg [{r.a_agg_deg.min():g}, {r.a_agg_deg.max():g}]° | "
              f"{cal.constraint['c_agg']} | {cal.constraint['a_agg_deg']} | {cal.chi2_min:.3g}/{cal.dof} |")
    impossible = ga.MeasuredDistribution.from_classes(EDGES[:-1], EDGES[1:], [0, 0.05, 0.05, 0.1, 0.6, 0.1, 0.05, 0.05, 0],
                                                      source="impossible: 60 % in 2.8-4.0 mm")
    cal = ga.calibrate_thresholds(cg1, impossible, C_GRID, A_GRID)
    print(f"\nimpossible distribution: {cal.summary()}")

    print("\nCG transfer: thresholds calibrated on lab-cg1 applied to the CG runs (original-system sizes)")
    m = grid_measurement(cg1, 0.45, 30.0, noise=0.01, seed=1)
    cal1 = ga.calibrate_thresholds(cg1, m, C_GRID, A_GRID)
    best = (cal1.best["c_agg"], cal1.best["a_agg_deg"])
    print(f"calibrated on lab-cg1: C_agg = {best[0]:g}, A_agg = {best[1]:g}°")
    print("| run | alpha | chi2/dof at the lab-cg1 pair | max abs(dP) | its own best pair | its chi2/dof | region |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in ("lab-cg1", "lab-cg2", "lab-cg3", ("lab-cg2", "lab-cg2-seed1", "lab-cg2-seed2"),
                 ("lab-cg3", "lab-cg3-seed1", "lab-cg3-seed2")):
        names = (name,) if isinstance(name, str) else name
        grids = [cg1 if n == "lab-cg1" else grid_of(n) for n in names]
        own = ga.calibrate_thresholds(grids, m, C_GRID, A_GRID)
        at = own.grid[(np.isclose(own.grid.c_agg, best[0])) & (np.isclose(own.grid.a_agg_deg, best[1]))].iloc[0]
        with ga.open_run(DATA / f"{names[0]}.h5") as run:
            alpha = run.meta.alpha
        label = names[0] if len(names) == 1 else f"{names[0]} + 2 replicas"
        print(f"| {label} | {alpha:g} | {at.chi2:.3g}/{own.dof} | {at.max_abs_dpassing:.3f} | {own.best['c_agg']:g}, "
              f"{own.best['a_agg_deg']:g}° | {own.chi2_min:.3g}/{own.dof} | C_agg {own.constraint['c_agg']}; "
              f"A_agg {own.constraint['a_agg_deg']} |")
    if args.figures:
        import matplotlib

        matplotlib.use("Agg")
        from granalytics.report.figures import calibration_figures

        cal = ga.calibrate_thresholds(DATA / "lab-cg1.h5", DATA / "sieve" / "example-sieve.csv", C_GRID, A_GRID)
        for name, fig in calibration_figures(cal).items():
            out = ROOT / "docs" / "figures" / f"{name}.png"
            fig.savefig(out, dpi=80, bbox_inches="tight")
            print(f"wrote {out}")


if __name__ == "__main__":
    main()
