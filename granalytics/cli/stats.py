"""The ``stats`` command: one run's granulation time series, its steady state and size distribution."""

from __future__ import annotations

import contextlib
import os

from granalytics.core.windows import clip_window
from granalytics.analysis.run_systems import check_replicas, run_identity
from granalytics.base.files import WriterLock
from granalytics.report import save
from granalytics.report.files import check_outputs, save_figure, staged_outputs
from granalytics.report.tables import format_steady_table
from granalytics.core import open_run
from granalytics.analysis.stats import DEFAULT_WINDOW_REV, check_window, run_stats, size_distribution, steady_state
from granalytics.cli.options import (add_frame_loop_options, add_gna_options, add_size_unit_option, criterion_params,
                                     frame_loop, progress, selected_frames, add_window_options, window_axis)


def add_stats_parser(sub):
    """Add the ``stats`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("stats", help="granulation time series and steady-state table",
                       description="Granule number, mean volume and yield per frame; steady-state averages over a revolution window.")
    p.add_argument("run", help="run file (.h5)")
    add_window_options(p)
    p.add_argument("--out", help="time series table to write (.csv or .parquet)")
    p.add_argument("--steady-out", help="steady-state table (mean, std, block s.e.m. per metric; .csv or .parquet)")
    p.add_argument("--sizes-out", help="granule-size distribution over the window (.csv or .parquet; sizes in "
                                        "--size-unit)")
    p.add_argument("--plot", help="figure of the time series and size distribution (.png, .pdf, .svg)")
    p.add_argument("--replica", action="append", default=[], metavar="RUN",
                   help="a replica of RUN (the same system at another seed; repeatable): the steady state is then "
                        "the mean over the replicas with the replica s.e. beside the block s.e.m. (also in --steady-out)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    add_size_unit_option(p)
    add_gna_options(p, time_twin=False)
    add_frame_loop_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_stats)
    return p


def cmd_stats(args):
    check_outputs(tables=(args.out, args.steady_out, args.sizes_out), plots=(args.plot,), overwrite=args.overwrite,
                  run=args.run)  # before the locks
    with contextlib.ExitStack() as locks:  # one writer at a time on each output (OUT.lock), checked again under it
        for path in (args.out, args.steady_out, args.sizes_out, args.plot):
            if path:
                locks.enter_context(WriterLock(path))
        return _stats(args)


def _stats(args):
    check_outputs(tables=(args.out, args.steady_out, args.sizes_out), plots=(args.plot,), overwrite=args.overwrite,
                  run=args.run)
    by, window = (("time_s", args.window_time) if args.window_time is not None
                  else ("revolutions", args.window if args.window is not None else DEFAULT_WINDOW_REV))
    params = dict(c_agg=args.c_agg, a_agg_deg=args.a_agg_deg, radius=args.radius, backend=args.backend,
                  cohesion=args.cohesion, **criterion_params(args))
    with open_run(args.run) as run:
        frames = selected_frames(run, args)
        # the window is checked on the frame times before the analysis (its warnings come with the table)
        axis = window_axis(frames, by)
        in_window, tol = check_window(axis, window, by=by, source=args.run, warn=False)
        used = clip_window(axis, *window, tol)  # the window over the run's frames (steady_state's)
        ts, sizes = run_stats(frames, "gna", progress=progress(args), return_sizes=True, **frame_loop(args), **params)
        meta = run.meta
    series = [ts]
    if args.replica:  # one system at other seeds, and no copy of a run (before the replicas' analysis)
        identities = []
        for path in [args.run, *args.replica]:
            with open_run(path) as replica:
                identities.append(run_identity(replica))
        check_replicas(identities)
    for path in args.replica:  # replicas: the steady state is over all of them (steady_state of a list)
        with open_run(path) as replica:
            series.append(run_stats(selected_frames(replica, args), "gna", progress=progress(args), **frame_loop(args),
                                    **params))
    steady = steady_state(series if args.replica else ts, window=window, by=by, source=args.run)
    dist = size_distribution([s for s, keep in zip(sizes, in_window) if keep], size_unit=args.size_unit, alpha=meta,
                             min_size=args.min_size or 2)  # the bins start at the smallest size that can occur
    with staged_outputs() as stage:  # every output, or none (a failing figure replaces no table)
        if args.out:
            save(ts, args.out, stage=stage)
        if args.steady_out:
            save(steady, args.steady_out, stage=stage)  # its index, the metric, as the first column
        if args.sizes_out:
            save(dist, args.sizes_out, stage=stage)
        if args.plot:
            import matplotlib.pyplot as plt

            from granalytics.report.figures import stats_figure

            test = (f"rigid_tol={args.rigid_tol:g}" if args.comotion == "rigid" else f"A_agg={args.a_agg_deg:g}°")
            fig = stats_figure(ts, dist, window=used, x=by,  # the window the mean is over, clipped to the run
                               title=f"{os.path.basename(args.run)}: GNA C_agg={args.c_agg:g}, {test}, "
                                     f"min_size={args.min_size}, cohesion={args.cohesion}"
                                     + (f" (window {window[0]:g}:{window[1]:g} clipped to the run)"
                                        if used != tuple(window) else ""))
            try:
                save_figure(fig, args.plot, stage)
                print(f"wrote plot to {args.plot}")
            finally:
                plt.close(fig)
    if args.out:
        print(f"wrote time series ({len(ts)} frames) to {args.out}")
    if args.steady_out:
        print(f"wrote the steady-state table to {args.steady_out}")
    if args.sizes_out:
        print(f"wrote size distribution to {args.sizes_out}")
    lo, hi = used
    clipped = f" (the window {window[0]:g}:{window[1]:g} clipped to the run's frames)" if used != tuple(window) else ""
    print(f"steady state over {'revolutions' if by == 'revolutions' else 'time [s]'} [{lo:.4g}, {hi:.4g}]{clipped} "
          f"(C_agg={args.c_agg:g}, A_agg={args.a_agg_deg:g}°, cohesion={args.cohesion})"
          + (f", mean over {args.run} and {len(args.replica)} replica(s):" if args.replica else ":"))
    print(format_steady_table(steady, by, replicas=bool(args.replica)))
    return 0
