"""The labels file of ``granalytics identify``: the granule of every particle in every frame, its
ids and its granule track, in one HDF5 file (datasets ``labels``, ``ids``, ``granule_track``,
``time``, ``frame_index``, ``n_granules``; attributes ``format``, ``run``, ``method``, ``params``,
``continuation``). Frames are identified and written one at a time, so a run larger than memory
fits; the file is renamed into place only when every frame is written."""

from __future__ import annotations

import json
import os

import numpy as np

from granalytics.base.errors import GranalyticsError
from granalytics.base.files import write_atomically

__all__ = ["write_labels"]


def write_labels(path, frames, identifier, *, run_path, n_particles, continuation="main",
                 progress=False) -> np.ndarray:
    """Identify every frame of ``frames`` with ``identifier`` and write the labels file ``path``
    atomically (the caller has checked it and holds its lock).

    Parameters
    ----------
    path : path
        The labels file (.h5).
    frames : Run or RunSlice
        The frames to identify, in order.
    identifier : Identifier
        :func:`granalytics.identification.make_identifier`'s.
    run_path : path
        The run file, recorded in the ``run`` attribute (as an absolute path).
    n_particles : int
        The run's particle count (the width of the datasets).
    continuation : {"main", "strict"}, default "main"
        Which granule keeps its track id (:func:`granalytics.track_granules`).
    progress : bool, default False
        Show a progress bar over frames.

    Returns
    -------
    (n_frames,) int64 array
        The number of granules in each frame.
    """
    import h5py

    def write(tmp):  # renamed into place only when every frame is written
        try:
            out = h5py.File(tmp, "w")
        except OSError as exc:
            raise GranalyticsError(f"{path}: cannot create labels file ({exc})") from None
        with out:
            _fill(out, frames, identifier, run_path, n_particles, continuation, progress)
            return out["n_granules"][:]

    return write_atomically(path, write)


def _fill(out, frames, identifier, run_path, n, continuation, progress):
    """Fill an open labels file: attributes, frame index and time, labels, ids and granule track
    ids per frame."""
    from granalytics.analysis.frames import map_frames
    from granalytics.analysis.tracking import track_granules

    n_frames = len(frames)
    out.attrs["format"] = "granalytics-labels"
    out.attrs["run"] = os.path.abspath(run_path)
    out.attrs["method"] = identifier.method
    out.attrs["params"] = json.dumps(identifier.params())
    out.attrs["continuation"] = continuation
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

    map_frames(frames, write_frame, progress=progress, desc="identify", what="identify")
    # the granule track of every particle (-1 free): the id that a granule keeps while it lives
    tracks = track_granules([labels[k] for k in range(n_frames)], [ids[k] for k in range(n_frames)], frames.times,
                            continuation=continuation)
    granule_track = out.create_dataset("granule_track", (n_frames, n), dtype=np.int64, **chunked)
    for k in range(n_frames):
        lab, mapping = labels[k], tracks.labels_to_tracks[k]
        granule_track[k] = np.where(lab >= 0, mapping[np.maximum(lab, 0)] if mapping.size else -1, -1)
