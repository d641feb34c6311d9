"""The ``compare-methods`` command: several identification methods on the same frames."""

from __future__ import annotations

import os
import warnings

from granalytics.core.windows import window_mask
from granalytics.analysis.metrics import HEADLINE
from granalytics.base.errors import ParameterError
from granalytics.report import save
from granalytics.report.files import check_outputs, save_figure
from granalytics.report.tables import format_method_means
from granalytics.identification import DEFAULT_METHODS
from granalytics.core import open_run
from granalytics.cli.options import (add_cohesion_option, add_frame_loop_options, frame_loop, revolution_window,
                                     selected_frames, setting, add_window_options, add_frame_window_options)


def add_compare_methods_parser(sub):
    """Add the ``compare-methods`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("compare-methods", help="compare identification methods frame by frame",
                       description="Run several identification methods on the same frames; adjusted Rand index and "
                                   "differences of granule number and yield for every pair.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--methods", type=lambda t: [m.strip() for m in t.split(",") if m.strip()],
                   default=list(DEFAULT_METHODS), help=f"comma-separated (default {','.join(DEFAULT_METHODS)})")
    p.add_argument("--set", action="append", type=setting, metavar="METHOD.PARAM=VALUE",
                   help="a method parameter, e.g. dbscan.eps_diameters=1.2 or gna.a_agg_deg=30 (repeatable); "
                        "custom.criterion takes comparisons of a contact-table column with a number joined by "
                        "and/or/not, e.g. 'custom.criterion=0.5 <= f_norm and (angle_v_deg < 30 or angle_w_deg < 30)' "
                        "(no arithmetic or function calls: docs/identification.md)")
    add_cohesion_option(p)
    add_frame_window_options(p, time_twin=False)
    add_window_options(p, what="steady-state window of the printed means")
    p.add_argument("--out", help="pairwise comparison per frame (.csv or .parquet)")
    p.add_argument("--stats-out", help="statistics per frame and method (.csv or .parquet)")
    p.add_argument("--plot", help="figure (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    add_frame_loop_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_compare)
    return p


def cmd_compare(args):
    from granalytics.analysis.method_comparison import compare_methods

    check_outputs(tables=(args.out, args.stats_out), plots=(args.plot,), overwrite=args.overwrite, run=args.run)
    methods = {name: (name, {}) for name in args.methods}
    for method, param, value in args.set or []:
        if method not in methods:
            raise ParameterError(f"--set {method}.{param}: {method!r} is not among --methods {','.join(methods)}")
        methods[method][1][param] = value
    with open_run(args.run) as run:
        args.window = revolution_window(args, [run.meta])
        frames = selected_frames(run, args)
        stats, pairs = compare_methods(frames, methods, cohesion=args.cohesion, progress=not args.quiet,
                                       **frame_loop(args))
    if args.out:
        save(pairs, args.out, overwrite=args.overwrite)
        print(f"wrote pairwise comparison to {args.out}")
    if args.stats_out:
        save(stats, args.stats_out, overwrite=args.overwrite)
        print(f"wrote per-method statistics to {args.stats_out}")
    if args.plot:
        from granalytics.report.figures import comparison_figure

        uses = [m for m in methods if m != "dbscan" or methods[m][1].get("bridged_only")]  # DBSCAN on positions has no F_coh
        save_figure(comparison_figure(stats, pairs, title=f"{os.path.basename(args.run)}, cohesion={args.cohesion} "
                                                          f"(for {', '.join(uses) or 'no method'})"), args.plot)
        print(f"wrote plot to {args.plot}")
    # the printed means are steady-state means over --window, as in stats (the tables hold every frame)
    lo, hi = args.window
    inside = window_mask(stats["revolutions"].to_numpy(dtype=float), lo, hi)
    if not inside.any():
        warnings.warn(f"{args.run}: no compared frame in the window [{lo:g}, {hi:g}] revolutions: the means below "
                      "are over every compared frame")
        inside[:] = True
    frames_in = set(stats["frame"][inside])
    mean_stats = stats[inside].groupby("method", sort=False)[list(HEADLINE)].mean()
    mean_pairs = pairs[pairs["frame"].isin(frames_in)].groupby(["method_a", "method_b"], sort=False)[
        ["ari", *(f"d_{name}" for name in HEADLINE)]].mean()
    print(format_method_means(mean_stats, mean_pairs, len(frames_in), args.window))
    return 0
