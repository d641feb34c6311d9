"""The ``identify`` command: the granule labels of every frame, written to an HDF5 file."""

from __future__ import annotations

import json
import os

import numpy as np

from granalytics.base.errors import GranalyticsError
from granalytics.base.files import WriterLock, write_atomically
from granalytics.report.files import check_outputs
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
    import h5py

    identifier = gna_identifier(args)
    check_outputs(others=(args.out,), overwrite=args.overwrite, run=args.run)
    # one writer at a time on the labels file (OUT.lock), the output checked again under the lock
    with WriterLock(args.out), open_run(args.run) as run:
        check_outputs(others=(args.out,), overwrite=args.overwrite, run=args.run)
        frames = selected_frames(run, args)
        n_frames, n = len(frames), run.n_particles

        def write(tmp):  # renamed into place only when every frame is written
            try:
                out = h5py.File(tmp, "w")
            except OSError as exc:
                raise GranalyticsError(f"{args.out}: cannot create labels file ({exc})") from None
            with out:
                _write_labels(out, args, frames, identifier, n_frames, n)
                return out["n_granules"][:]

        counts = write_atomically(args.out, write)
    print(f"wrote {args.out}: labels of {n} particles in {n_frames} frames "
          f"(granules per frame: min {counts.min()}, mean {counts.mean():.1f}, max {counts.max()})")
    return 0


def _write_labels(out, args, frames, identifier, n_frames, n):
    """Fill an open labels file: attributes, frame index and time, labels, ids and granule track
    ids per frame."""
    from granalytics.analysis.frames import map_frames

    out.attrs["format"] = "granalytics-labels"
    out.attrs["run"] = os.path.abspath(args.run)
    out.attrs["method"] = identifier.method
    out.attrs["params"] = json.dumps(identifier.params())
    out.attrs["continuation"] = args.continuation
    out["frame_index"] = frames.frame_indices
    out["time"] = frames.times
    out["time"].attrs["unit"] = "s"
    chunked = dict(chunks=(1, n), compression="gzip", shuffle=True)
    labels = out.create_dataset("labels", (n_frames, n), dtype=np.int32, **chunked)
    ids = out.create_dataset("ids", (n_frames, n), dtype=np.int64, **chunked)
    n_granules = out.create_dataset("n_granules", (n_frames,), dtype=np.int64)
    written = iter(range(n_frames))  # one thread: the frames come in order

    def write_frame(snapshot):
        k, result = next(written), identifier.identify(snapshot)
        labels[k], ids[k], n_granules[k] = result.labels, snapshot.ids, result.n_granules

    map_frames(frames, write_frame, progress=progress(args), desc="identify", what="identify")
    # the granule track of every particle (-1 free): the id that a granule keeps while it lives
    from granalytics.analysis.tracking import track_granules

    tracks = track_granules([labels[k] for k in range(n_frames)], [ids[k] for k in range(n_frames)], frames.times,
                            continuation=args.continuation)
    granule_track = out.create_dataset("granule_track", (n_frames, n), dtype=np.int64, **chunked)
    for k in range(n_frames):
        lab, mapping = labels[k], tracks.labels_to_tracks[k]
        granule_track[k] = np.where(lab >= 0, mapping[np.maximum(lab, 0)] if mapping.size else -1, -1)
