"""The ``sensitivity`` command: GNA's statistics over a C_agg × A_agg grid."""

from __future__ import annotations

import os

from granalytics.base.resources import check_memory
from granalytics.base.errors import ParameterError
from granalytics.report import save
from granalytics.report.files import check_outputs, save_figure
from granalytics.report.tables import format_sensitivity_means
from granalytics.identification.contacts import warn_if_c_agg_unreachable
from granalytics.core import open_run
from granalytics.analysis.stats import check_window
from granalytics.cli.options import (resolve_rigid_options, add_cohesion_option, add_criterion_options,
                                     add_frame_loop_options, frame_loop, grid, revolution_window, add_window_options,
                                     warn_if_unfinished, window_axis)


def add_sensitivity_parser(sub):
    """Add the ``sensitivity`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("sensitivity", help="GNA statistics over a C_agg × A_agg grid",
                       description="Yield, granule number and mean granule volume of every frame in a revolution window "
                                   "at every (C_agg, A_agg), the C_agg axis in one pass per frame; mean ± std over the window.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--c-agg", type=grid, default=grid("0.1:1.0:19"), metavar="GRID",
                   help="cohesion thresholds: START:STOP:NUM or a list (default 0.1:1.0:19)")
    p.add_argument("--a-agg-deg", type=grid, default=grid("5,10,20,45,90"), metavar="GRID",
                   help="angle thresholds in degrees (default 5,10,20,45,90)")
    add_window_options(p, what="window of the frames averaged")
    p.add_argument("--radius", choices=("pair", "mean"), default="pair", help="R in 2πγR (default pair)")
    add_cohesion_option(p)
    add_criterion_options(p, grid_tol=True)
    add_frame_loop_options(p)
    p.add_argument("--out", help="summary table over the window (.csv or .parquet)")
    p.add_argument("--frames-out", help="per-frame table (.csv or .parquet)")
    p.add_argument("--plot", help="heatmaps and line plots (.png, .pdf, .svg)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sensitivity)
    return p


def cmd_sensitivity(args):
    from granalytics.analysis.sensitivity import sensitivity, sensitivity_summary

    check_outputs(tables=(args.out, args.frames_out), plots=(args.plot,), overwrite=args.overwrite, run=args.run)
    if (args.c_agg < 0).any():
        raise ParameterError(f"--c-agg values must be >= 0, got min {args.c_agg.min():g}")
    bad = [a for a in args.a_agg_deg if not 0 < a <= 180]
    if bad:
        raise ParameterError(f"--a-agg-deg values must be in (0, 180] degrees, got {bad[0]:g}")
    resolve_rigid_options(args, grid_tol=True)
    if (args.rigid_tol <= 0).any():
        raise ParameterError(f"--rigid-tol values must be > 0, got min {args.rigid_tol.min():g}")
    rigid = args.comotion == "rigid"
    thresholds = dict(a_agg_deg=None if rigid else args.a_agg_deg, rigid_tol=args.rigid_tol if rigid else None,
                      comotion=args.comotion, rigid_scale=args.rigid_scale, min_size=args.min_size)
    with open_run(args.run) as run:
        warn_if_unfinished(run)
        args.window = revolution_window(args, [run.meta])
        check_window(window_axis(run), args.window, source=args.run)  # refuses an empty window, warns for an uncovered one
        frames = run.select(revolutions=args.window)
        # the per-frame table: one row of about 120 bytes per frame and grid point, built in memory
        points = len(args.c_agg) * (len(args.rigid_tol) if rigid else len(args.a_agg_deg))
        check_memory(f"sensitivity over {len(frames)} frames × {points} grid points", 120 * 2 * len(frames) * points)
        if len(frames):
            warn_if_c_agg_unreachable(frames, args.c_agg, args.cohesion, args.radius)
        table = sensitivity(frames, args.c_agg, radius=args.radius, cohesion=args.cohesion, progress=not args.quiet,
                            **frame_loop(args), **thresholds)
    summary = sensitivity_summary(table)
    if args.frames_out:
        save(table, args.frames_out, overwrite=args.overwrite)
        print(f"wrote per-frame table ({len(table)} rows) to {args.frames_out}")
    if args.out:
        save(summary, args.out, overwrite=args.overwrite)
        print(f"wrote summary over {len(frames)} frames ({len(summary)} grid points) to {args.out}")
    if args.plot:
        from granalytics.report.figures import sensitivity_figure

        save_figure(sensitivity_figure(summary, title=f"{os.path.basename(args.run)}, revolutions "
                                 f"[{args.window[0]:g}, {args.window[1]:g}], cohesion={args.cohesion}"), args.plot)
        print(f"wrote plot to {args.plot}")
    print(format_sensitivity_means(summary, args.window, args.cohesion, rigid=rigid))
    return 0
