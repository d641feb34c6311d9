"""The ``track`` command: granule life histories, events, rates, the coalescence kernel (docs/tracking.md)."""

from __future__ import annotations

import math
import os

from granalytics.base.errors import ParameterError
from granalytics.base.files import WriterLock
from granalytics.report.files import output_folder
from granalytics.identification import DEFAULT_METHODS, accepted_params
from granalytics.core import open_run
from granalytics.analysis.tracking import KINDS, GranuleTracks, track_run
from granalytics.cli.options import (add_cohesion_option, add_frame_loop_options, add_frame_window_options,
                                     add_size_unit_option, frame_loop, selected_frames, threshold_options)


def add_track_parser(sub):
    """Add the ``track`` command to ``sub`` (``ArgumentParser.add_subparsers``).

    Returns
    -------
    argparse.ArgumentParser
        The subcommand's parser (``func`` defaults to :func:`cmd_track`).
    """
    p = sub.add_parser(
        "track", help="granule tracks, coalescence and breakage events, population-balance rates",
        description="Identify granules in every frame, follow them from frame to frame by their particle ids and "
                    "record births, deaths, coalescences and breakages; write the events, the tracks (size "
                    "histories), event rates per revolution, the coalescence kernel β(i, j), the breakage "
                    "rate S(i) and a figure. See docs/tracking.md.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True,
                   help="output folder: events.csv, tracks.csv, rates.csv, kernel.csv, breakage.csv, tracking.png")
    p.add_argument("--method", choices=DEFAULT_METHODS, default="gna",
                   help="identification method (default gna)")
    p.add_argument("--c-agg", type=float, default=None,
                   help="cohesion threshold C_agg (default: the method's, 0.6; only for methods that take it)")
    p.add_argument("--a-agg-deg", type=float, default=None,
                   help="angle threshold A_agg in degrees (default: the method's, 20; only for methods that take it)")
    add_cohesion_option(p)
    add_frame_window_options(p)
    p.add_argument("--min-fragment", type=int, default=2,
                   help="fewest particles that count as a fragment in a coalescence or breakage (default 2)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    add_size_unit_option(p)
    add_frame_loop_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_track)
    return p


def cmd_track(args):
    """Run the ``track`` subcommand (see :func:`add_track_parser`); returns the exit status 0."""
    from granalytics.report import output_paths, save

    if args.min_fragment < 1:
        raise ParameterError(f"--min-fragment must be >= 1, got {args.min_fragment}")
    # the folder made before the analysis (removed again if the command fails and leaves it empty),
    # one writer at a time into it (OUT/tracking.lock), the outputs checked under the lock and
    # written as one (granalytics.save)
    with output_folder(args.out), WriterLock(os.path.join(args.out, "tracking")):
        output_paths(GranuleTracks, args.out, overwrite=args.overwrite)
        params = {**threshold_options(args, args.method), **accepted_params(args.method, cohesion=args.cohesion)}
        with open_run(args.run) as run:
            omega, meta = run.meta.drum_omega, run.meta
            frames = selected_frames(run, args)
            if len(frames) < 2:
                raise ParameterError(f"{args.run}: tracking needs at least two frames, the selection has {len(frames)} "
                                     f"(the run has {len(run)})")
            tracks = track_run(frames, args.method, progress=not args.quiet, min_fragment=args.min_fragment,
                               **frame_loop(args), **params)
        setting = ", ".join(f"{k}={v}" for k, v in params.items())
        written = save(tracks, args.out, overwrite=args.overwrite,
                       revolution_period_s=2 * math.pi / abs(omega) if omega else None, size_unit=args.size_unit,
                       alpha=meta, title=f"{os.path.basename(args.run)}: {args.method} ({setting}), "
                                         f"min_fragment={args.min_fragment}")
        counts = tracks.event_counts()
        print(f"wrote plot to {written[-1]}")
        print(f"wrote {len(written)} files to {args.out}: {tracks.n_tracks} tracks over {tracks.n_frames} frames; "
              + ", ".join(f"{kind} {counts[kind]}" for kind in KINDS))
        return 0
