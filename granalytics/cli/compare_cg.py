"""The ``compare-cg`` command: runs of one system at several CG factors (the paper's Figs 3–6)."""

from __future__ import annotations

import argparse
import os

import numpy as np

from granalytics.analysis.metrics import METRICS
from granalytics.base.errors import ParameterError
from granalytics.report.tables import format_cg_table
from granalytics.identification import DEFAULT_METHODS, accepted_params
from granalytics.identification.common import PAPER_A_AGG_DEG, PAPER_C_AGG
from granalytics.cli.options import (threshold_options, add_cohesion_option, add_criterion_options,
                                     add_size_unit_option, criterion_params, grid, revolution_window, run_items,
                                     run_metas, setting, add_window_options)


def add_compare_cg_parser(sub):
    """Add the ``compare-cg`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("compare-cg", help="compare runs at several CG factors (paper Figs 3–6)",
                       description="Granule volume, number, size distribution and yield of runs of one system at "
                                   "several CG factors α: the paper's Figs 3–6 (PNG and PDF), a table of steady-state "
                                   "mean ± block s.e.m. (± replica s.e., the block s.e.m. beside it, with --replicas) "
                                   "with the relative deviation from the finest run ± its s.e., the "
                                   "Kolmogorov–Smirnov distance of the size distributions, and the measured CG speed-up.")
    p.add_argument("runs", nargs="+", help="run files (.h5), at least two; a folder is the statistics kept of a run "
                                           "in place of its frames (granalytics.RunStatistics)")
    p.add_argument("--out", required=True, help="output folder: cg_table.csv, cg_timeseries.csv, cg_sizes.csv, fig3–fig6 .png/.pdf")
    p.add_argument("--labels", help="comma-separated run names (default: CG<α> (<N> particles))")
    p.add_argument("--replicas", action="store_true",
                   help="runs with equal α and particle count are replicas (other seeds) of one system: compare "
                        "their mean, with the replica standard error beside the block s.e.m. (one label per group)")
    add_window_options(p)
    p.add_argument("--mixed-systems", action="store_true",
                   help="compare runs that are not coarse-grained from one original system (their original "
                        "parameters differ in more than seed, α and CG rule) with a warning instead of a refusal")
    p.add_argument("--method", choices=DEFAULT_METHODS, default="gna",
                   help="identification method (default gna, the paper's)")
    p.add_argument("--c-agg", type=grid, default=None, metavar="C",
                   help="cohesion threshold C_agg (default 0.6; only for methods that take it); a grid "
                        "(START:STOP:NUM or a list) compares the runs at every threshold pair instead")
    p.add_argument("--a-agg-deg", type=grid, default=None, metavar="A",
                   help="angle threshold A_agg in degrees (default 20); a grid (e.g. 10,20,45) as for --c-agg")
    p.add_argument("--set", action="append", type=lambda t: setting("method." + t)[1:], metavar="PARAM=VALUE",
                   help="another method parameter, e.g. radius=mean or eps_diameters=1.2 (repeatable)")
    add_cohesion_option(p)
    add_criterion_options(p)
    add_size_unit_option(p)
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare_cg)
    return p


def _paper_criterion(args) -> bool:
    """Whether the co-motion and size-floor options are the paper's (angle test, pairs count)."""
    return criterion_params(args) == {"comotion": "angle", "min_size": 2}


def cmd_compare_cg(args):
    from granalytics.analysis.cg import CGComparison, compare_cg, group_replicas
    from granalytics.report import output_paths, save

    labels = [x.strip() for x in args.labels.split(",")] if args.labels else None
    grids = [g for g in (args.c_agg, args.a_agg_deg) if g is not None]
    if any(len(g) > 1 for g in grids):
        if args.replicas:
            raise ParameterError("--replicas: a threshold grid compares single runs; leave --replicas out")
        return _compare_cg_thresholds(args, labels)
    # one value each: the standard comparison at that pair (args keep their grids)
    single = argparse.Namespace(**{name: None if getattr(args, name) is None else float(getattr(args, name)[0])
                                   for name in ("c_agg", "a_agg_deg")})
    params = threshold_options(single, args.method)
    criterion = criterion_params(args)
    if args.method != "gna" and not _paper_criterion(args):
        raise ParameterError(f"--comotion / --min-size: method {args.method!r} has no such parameters (GNA's)")
    params.update(accepted_params(args.method, **criterion))
    for param, value in args.set or []:
        params[param] = value
    output_paths(CGComparison, args.out, overwrite=args.overwrite)  # before minutes of analysis
    items = run_items(args.runs)
    runs = group_replicas(items) if args.replicas else items
    args.window = revolution_window(args, run_metas(items), args.runs)
    comparison = compare_cg(runs, labels, window=args.window, method=args.method, cohesion=args.cohesion,
                            progress=not args.quiet, mixed_systems=args.mixed_systems, **params)
    written = save(comparison, args.out, overwrite=args.overwrite, size_unit=args.size_unit)
    print(f"wrote {len(written)} files to {args.out}: " + ", ".join(os.path.basename(p) for p in written))
    print(format_cg_table(comparison))
    return 0


def _compare_cg_thresholds(args, labels) -> int:
    """compare-cg with a grid of thresholds: the deviation table and one heatmap per statistic."""
    from granalytics.analysis.cg import CGThresholdComparison, compare_cg_thresholds
    from granalytics.analysis.metrics import BY_FIGURE
    from granalytics.report import output_paths, save

    if args.method != "gna":
        raise ParameterError(f"--method {args.method}: a threshold grid is GNA's C_agg x A_agg (give --method gna)")
    if args.set:
        raise ParameterError("--set: a threshold grid runs GNA at its defaults otherwise; leave --set out")
    if not _paper_criterion(args):
        raise ParameterError("--comotion rigid / --min-size: a threshold grid is the paper's C_agg x A_agg at "
                             "min_size 2; compare with one threshold pair, or use granalytics sensitivity")
    c_agg = args.c_agg if args.c_agg is not None else np.array([PAPER_C_AGG])
    a_agg = args.a_agg_deg if args.a_agg_deg is not None else np.array([PAPER_A_AGG_DEG])
    if (c_agg < 0).any() or ((a_agg <= 0) | (a_agg > 180)).any():
        raise ParameterError("--c-agg values must be >= 0 and --a-agg-deg values in (0, 180] degrees")
    output_paths(CGThresholdComparison, args.out, overwrite=args.overwrite)  # before minutes of analysis
    items = run_items(args.runs)
    args.window = revolution_window(args, run_metas(items), args.runs)
    comparison = compare_cg_thresholds(items, c_agg, a_agg, labels, window=args.window, cohesion=args.cohesion,
                                       progress=not args.quiet)
    written = save(comparison, args.out, overwrite=args.overwrite)
    table, finest = comparison.table, comparison.finest
    worst = table[table["run"] != finest]
    print(f"wrote {len(written)} files to {args.out}: the deviation from {finest} at {len(c_agg) * len(a_agg)} threshold "
          f"pairs (window [{args.window[0]:g}, {args.window[1]:g}] revolutions, cohesion={args.cohesion})")
    for metric in BY_FIGURE:
        dev = worst[f"{metric}_rel_dev"].abs()
        if dev.notna().any():
            row = worst.loc[dev.idxmax()]
            print(f"  {METRICS[metric].label}: largest |deviation| {100 * dev.max():.0f} % ({row['run']}, C_agg = "
                  f"{row['c_agg']:g}, A_agg = {row['a_agg_deg']:g}°), median {100 * dev.median():.0f} %")
    return 0
