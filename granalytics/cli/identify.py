"""The ``identify`` command: the granule labels of every frame, written to an HDF5 file."""

from __future__ import annotations

from granalytics.base.files import WriterLock
from granalytics.report.files import check_outputs
from granalytics.report.labels import write_labels
from granalytics.core import open_run
from granalytics.cli.options import add_continuation_option, add_gna_options, gna_identifier, progress, selected_frames


def add_identify_parser(sub):
    """Add the ``identify`` command to ``sub`` (``ArgumentParser.add_subparsers``)."""
    p = sub.add_parser("identify", help="granule labels per frame to a file",
                       description="Identify granules in every frame and write the labels (−1 = free particle) to an HDF5 file.")
    p.add_argument("run", help="run file (.h5)")
    p.add_argument("--out", required=True, help="labels file to write (.h5): datasets labels, ids, granule_track, time, frame_index, n_granules")
    p.add_argument("--overwrite", action="store_true", help="replace an existing labels file")
    add_gna_options(p)
    add_continuation_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_identify)
    return p


def cmd_identify(args):
    identifier = gna_identifier(args)
    check_outputs(others=(args.out,), overwrite=args.overwrite, run=args.run)
    # one writer at a time on the labels file (OUT.lock), the output checked again under the lock
    with WriterLock(args.out), open_run(args.run) as run:
        check_outputs(others=(args.out,), overwrite=args.overwrite, run=args.run)
        frames = selected_frames(run, args)
        n_frames, n = len(frames), run.n_particles
        counts = write_labels(args.out, frames, identifier, run_path=args.run, n_particles=n,
                              continuation=args.continuation, progress=progress(args))
    print(f"wrote {args.out}: labels of {n} particles in {n_frames} frames "
          f"(granules per frame: min {counts.min()}, mean {counts.mean():.1f}, max {counts.max()})")
    return 0
