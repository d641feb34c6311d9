"""The ``calibrate`` command: fit C_agg and A_agg (or the rigid tolerance) to a measured sieve analysis."""

from __future__ import annotations

import os

from granalytics.cli.options import (add_cohesion_option, add_criterion_options, add_window_options, grid,
                                     resolve_rigid_options, revolution_window, run_metas)
from granalytics.base.errors import ParameterError

__all__ = ["add_calibrate_parser", "cmd_calibrate"]


def add_calibrate_parser(sub):
    """Add the ``calibrate`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    from granalytics.analysis.calibration import DEFAULT_MEASURED_ERROR, SIZE_MEASURES, Calibration
    from granalytics.report import output_names

    p = sub.add_parser("calibrate", help="fit C_agg and A_agg to a measured sieve analysis",
                       description="Sieve GNA's granules into the classes of a measured size distribution at every "
                                   "(C_agg, A_agg) of a grid (one pass per frame), average over the window, and find "
                                   "the pair whose distribution is closest (chi2 of the cumulative mass passing, "
                                   "weighted by the errors), with a bootstrap confidence region. Several runs are "
                                   "replicas of one system. Writes tables, calibration.json and two figures into --out.")
    p.add_argument("runs", nargs="+", metavar="RUN", help="run file(s) (.h5); several: replicas of one system")
    p.add_argument("--measured", required=True, metavar="CSV",
                   help="measured sieve analysis: lower_m,upper_m,mass_fraction[,sigma] or "
                        "aperture_m,passing_fraction[,sigma] (docs/calibration.md)")
    p.add_argument("--c-agg", type=grid, default=grid("0.2:0.9:15"), metavar="GRID",
                   help="cohesion thresholds: START:STOP:NUM or a list (default 0.2:0.9:15)")
    p.add_argument("--a-agg-deg", type=grid, default=None, metavar="GRID",
                   help="angle thresholds in degrees (default 5:60:12)")
    add_window_options(p)
    p.add_argument("--measure", choices=tuple(SIZE_MEASURES), default="volume",
                   help="a granule's size: 'volume' = diameter of the sphere of its solid volume (default), "
                        "'width' = its second-largest principal extent")
    p.add_argument("--measured-error", type=float, default=DEFAULT_MEASURED_ERROR, metavar="SIGMA",
                   help="standard error of the measured cumulative fraction passing, when the file has no sigma "
                        f"column (default {DEFAULT_MEASURED_ERROR:g})")
    p.add_argument("--bootstrap", type=int, default=200, metavar="N", help="bootstrap replicas (default 200)")
    p.add_argument("--block-rev", type=float, default=0.5, metavar="REV",
                   help="bootstrap block length in revolutions (default 0.5)")
    p.add_argument("--level", type=float, default=0.95, help="confidence level of the region (default 0.95)")
    p.add_argument("--seed", type=int, default=0, help="seed of the bootstrap (default 0)")
    p.add_argument("--radius", choices=("pair", "mean"), default="pair", help="R in 2πγR (default pair)")
    add_cohesion_option(p)
    add_criterion_options(p, grid_tol=True)
    p.add_argument("--jobs", type=int, default=1, help="worker threads over frames (default 1)")
    p.add_argument("--out", required=True, metavar="FOLDER",
                   help="output folder: " + ", ".join(output_names(Calibration)))
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_calibrate)
    return p


def cmd_calibrate(args):
    from granalytics.analysis.calibration import Calibration, calibrate_thresholds, read_sieve_csv
    from granalytics.report import output_paths, save

    if args.comotion == "rigid" and args.a_agg_deg is not None:
        raise ParameterError("--a-agg-deg: --comotion rigid sweeps --rigid-tol instead; leave --a-agg-deg out")
    resolve_rigid_options(args, grid_tol=True)
    rigid = args.comotion == "rigid"
    a_agg = None if rigid else (args.a_agg_deg if args.a_agg_deg is not None else grid("5:60:12"))
    for path in args.runs:
        if os.path.realpath(path) == os.path.realpath(args.out):
            raise ParameterError(f"{args.out}: the output folder is an input run")
    measured = read_sieve_csv(args.measured)  # a malformed file is refused before any run is read
    output_paths(Calibration, args.out, overwrite=args.overwrite)  # before the work
    args.window = revolution_window(args, run_metas(args.runs), args.runs)
    cal = calibrate_thresholds(args.runs, measured, args.c_agg, a_agg, window=args.window, comotion=args.comotion,
                               rigid_tol=args.rigid_tol if rigid else None, rigid_scale=args.rigid_scale,
                               measure=args.measure, measured_error=args.measured_error, n_boot=args.bootstrap,
                               block_rev=args.block_rev, level=args.level, seed=args.seed, radius=args.radius,
                               cohesion=args.cohesion, min_size=args.min_size, jobs=args.jobs,
                               progress=not args.quiet)
    paths = save(cal, args.out, overwrite=args.overwrite)
    print(f"wrote {len(paths)} files to {args.out}: " + ", ".join(os.path.basename(p) for p in paths))
    print(cal.summary())
    return 0
