"""The ``pbm`` command: a population balance fed by the DEM's tracked granules, beside the DEM
(docs/population_balance.md)."""

from __future__ import annotations

import argparse
import os

from granalytics.cli.options import add_cohesion_option, interval, revolution_window, threshold_options
from granalytics.base.errors import ParameterError
from granalytics.base.files import WriterLock


def add_pbm_parser(sub):
    """Add the ``pbm`` command to ``sub`` (``ArgumentParser.add_subparsers``).

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser (``func`` defaults to :func:`cmd_pbm`).
    """
    from granalytics.identification import DEFAULT_METHODS

    p = sub.add_parser(
        "pbm", help="population balance: rates measured on one window, predicted size distributions of a later one",
        description="Identify and track granules, measure the coalescence kernel, breakage, layering, nucleation and "
                    "erosion rates on the fit window, integrate the population balance from the DEM's distribution at "
                    "the start of the prediction window and write it beside the DEM's own distributions: kernel.csv "
                    "(β(i, j) [1/s per pair]), rates.csv (per size class: S, fragments, λ, E [1/s]), "
                    "distributions.csv (both distributions at every frame, on the PBM's pivots), summary.csv "
                    "(mean size, yield, KS distance per frame), settings.json and pbm.png (DEM as points, PBM as "
                    "lines). See docs/population_balance.md.")
    p.add_argument("run", help="run file (.h5)")
    fit = p.add_mutually_exclusive_group(required=True)
    fit.add_argument("--fit-window", type=interval, metavar="R0:R1", help="revolutions whose tracked granules give the rates")
    fit.add_argument("--fit-window-time", type=interval, metavar="T0:T1", help="the same in seconds")
    predict = p.add_mutually_exclusive_group(required=True)
    predict.add_argument("--predict", type=interval, metavar="R0:R1",
                         help="revolutions to predict, from the DEM's distribution at the first frame in it")
    predict.add_argument("--predict-time", type=interval, metavar="T0:T1", help="the same in seconds")
    p.add_argument("--out", required=True, help="output folder: kernel.csv, rates.csv, distributions.csv, summary.csv, "
                                                "settings.json, pbm.png")
    p.add_argument("--method", choices=DEFAULT_METHODS, default="gna", help="identification method (default gna)")
    p.add_argument("--c-agg", type=float, default=None,
                   help="cohesion threshold C_agg (default: the method's, 0.6; only for methods that take it)")
    p.add_argument("--a-agg-deg", type=float, default=None,
                   help="angle threshold A_agg in degrees (default: the method's, 20; only for methods that take it)")
    add_cohesion_option(p)
    p.add_argument("--min-fragment", type=int, default=2,
                   help="fewest particles of a breakage fragment, in the tracking and in the PBM (default 2)")
    p.add_argument("--bins-per-decade", type=float, default=4, help="size classes of the rates per decade (default 4)")
    p.add_argument("--ratio", type=float, default=2 ** 0.25,
                   help="ratio of successive pivots of the PBM's size grid above the all-integer sizes (default 2^0.25)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_pbm)
    return p


def cmd_pbm(args):
    """Run the ``pbm`` subcommand (see :func:`add_pbm_parser`); returns the exit status 0."""
    import granalytics as ga
    from granalytics.analysis.population_balance import PBMPrediction
    from granalytics.identification import accepted_params
    from granalytics.report import output_paths, save
    from granalytics.report.files import output_folder

    if args.min_fragment < 1:
        raise ParameterError(f"--min-fragment must be >= 1, got {args.min_fragment}")
    if not args.bins_per_decade > 0:
        raise ParameterError(f"--bins-per-decade must be positive, got {args.bins_per_decade:g}")
    if not 1 < args.ratio <= 10:
        raise ParameterError(f"--ratio must be in (1, 10], got {args.ratio:g}")
    with ga.open_run(args.run) as run:
        meta = run.meta
    for name in ("fit_window", "predict"):  # seconds to revolutions at the run's Ω
        seconds = getattr(args, f"{name}_time")
        if seconds is not None:
            setattr(args, name, revolution_window(argparse.Namespace(window_time=seconds), [meta]))
    if args.predict[0] < args.fit_window[0]:
        raise ParameterError(f"--predict {args.predict[0]:g}:{args.predict[1]:g} starts before --fit-window "
                             f"{args.fit_window[0]:g}:{args.fit_window[1]:g} (a prediction goes forward)")
    # the folder made before the analysis (removed again if the command fails and leaves it empty),
    # one writer at a time into it (OUT/pbm.lock), the outputs checked under the lock and written
    # as one (granalytics.save)
    with output_folder(args.out), WriterLock(os.path.join(args.out, "pbm")):
        output_paths(PBMPrediction, args.out, overwrite=args.overwrite)
        params = {**threshold_options(args, args.method), **accepted_params(args.method, cohesion=args.cohesion)}
        with ga.open_run(args.run) as run:
            pred = ga.pbm_from_run(run, args.fit_window, args.predict, method=args.method,
                                   min_fragment=args.min_fragment, bins_per_decade=args.bins_per_decade,
                                   ratio=args.ratio, progress=not args.quiet, **params)
        if not pred.pbm.success:
            raise ParameterError(f"{args.run}: the population balance did not integrate ({pred.pbm.message})")
        written = save(pred, args.out, overwrite=args.overwrite)
        summary = pred.summary()
        last = summary.iloc[-1]
        print(f"wrote plot to {written[-1]}")
        print(f"wrote {len(written)} files to {args.out}: at revolution {last['revolution']:.2f} the PBM has mean size "
              f"{last['pbm_mean_size']:.2f} and yield {last['pbm_yield_fraction']:.3f}, the DEM "
              f"{last['dem_mean_size']:.2f} and {last['dem_yield_fraction']:.3f} (KS D {last['ks_d']:.3f}); "
              f"particles kept to {pred.pbm.mass_error:.1e}")
        return 0
