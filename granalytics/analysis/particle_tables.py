"""A tidy per-particle table (one row per particle and frame, as trackpy users expect), with each
particle's granule and the granule's track id, which keeps its value while the granule lives.

Granule labels are renumbered in every frame (largest first); a track id follows one granule
from frame to frame by its particles (:mod:`granalytics.analysis.tracking`, rules in ``docs/tracking.md``).
By default (``continuation="main"``) a granule keeps its id through the events it survives: the
piece that keeps most of a breaking granule, and the coalescence of which it is the largest
contributor, carry it on; with ``continuation="strict"`` every coalescence and breakage starts
new ids.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from granalytics.analysis.frames import frame_indices as _frame_indices

__all__ = ["PARTICLE_COLUMNS", "particle_frames", "particle_table", "granule_tracks",
           "granule_track_table"]

#: columns of :func:`particle_table`, with units
PARTICLE_COLUMNS = {
    "frame": "index of the frame in the run file", "time_s": "s", "revolutions": "t·Ω/2π",
    "id": "particle id", "x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s",
    "wx": "rad/s", "wy": "rad/s", "wz": "rad/s", "radius": "m", "film_volume": "m³",
    "granule": "label in this frame (−1 free)", "granule_track": "track id over frames (−1 free)",
}


def granule_tracks(frames, method="gna", *, min_fragment=2, continuation="main", progress=False, **params):
    """Granule labels of every frame and the tracks that follow them.

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
    method, params
        Identification, as :func:`granalytics.identify`.
    min_fragment : int, default 2
        Smallest fragment of a coalescence or breakage [particles] (:func:`granalytics.track_granules`).
    continuation : {"main", "strict"}, default "main"
        Which granule keeps a track id through coalescence and breakage
        (:func:`granalytics.track_granules`): the main branch, or none.
    progress : bool, default False
        Show a progress bar over frames.

    Returns
    -------
    labels : list of (N,) int64 arrays
        The granule of each particle in each frame (−1 free).
    tracks : GranuleTracks
        :func:`granalytics.track_granules` of those labels; ``tracks.labels_to_tracks[k][label]``
        is the track id of granule ``label`` of frame k.
    """
    from granalytics.analysis.tracking import track_run

    return track_run(frames, method, progress=progress, min_fragment=min_fragment, continuation=continuation,
                     return_labels=True, **params)


def particle_frames(frames, method="gna", *, min_fragment=2, continuation="main", progress=False, **params):
    """Yield the :func:`particle_table` of one frame at a time (the run is read twice, one frame in
    memory at a time besides the labels): for tables larger than memory, written piece by piece
    (:func:`granalytics.report.files.stream_table`).
    The arguments are :func:`particle_table`'s."""
    labels, tracks = granule_tracks(frames, method, min_fragment=min_fragment, continuation=continuation,
                                    progress=progress, **params)
    indices = _frame_indices(frames)
    for k, snapshot in enumerate(frames):
        lab = labels[k]
        mapping = tracks.labels_to_tracks[k]
        track = np.where(lab >= 0, mapping[np.maximum(lab, 0)] if mapping.size else -1, -1)
        p, v, w = snapshot.position, snapshot.velocity, snapshot.angular_velocity
        yield pd.DataFrame({
            "frame": np.full(snapshot.n_particles, int(indices[k]), dtype=np.int64),
            "time_s": snapshot.time, "revolutions": snapshot.revolutions, "id": snapshot.ids,
            "x": p[:, 0], "y": p[:, 1], "z": p[:, 2], "vx": v[:, 0], "vy": v[:, 1], "vz": v[:, 2],
            "wx": w[:, 0], "wy": w[:, 1], "wz": w[:, 2], "radius": snapshot.radius,
            "film_volume": snapshot.film_volume, "granule": lab.astype(np.int64), "granule_track": track.astype(np.int64),
        })


def particle_table(frames, method="gna", *, min_fragment=2, continuation="main", progress=False,
                   **params) -> pd.DataFrame:
    """One row per particle and frame: :data:`PARTICLE_COLUMNS` (SI units).

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
        E.g. ``run.select(revolutions=(3, 6))``: only these frames are read, one at a time.
    method, params
        Identification (default GNA at the paper's thresholds), as :func:`granalytics.identify`.
    min_fragment : int, default 2
        Smallest fragment of a coalescence or breakage [particles] (:func:`granalytics.track_granules`).
    continuation : {"main", "strict"}, default "main"
        Which granule keeps its ``granule_track`` through coalescence and breakage
        (:func:`granalytics.track_granules`): ``"main"``, the piece that keeps most of a breaking
        granule and the coalescence of which a granule is the largest contributor; ``"strict"``,
        none (every coalescence and breakage starts new ids, as the tracks of the kinetics).
    progress : bool, default False
        Show a progress bar over frames.

    Returns
    -------
    DataFrame
        Sorted by frame, then particle row. ``granule_track`` is the same for a granule in every
        frame of its life; ``granule`` is renumbered per frame.
    """
    parts = list(particle_frames(frames, method, min_fragment=min_fragment, continuation=continuation,
                                 progress=progress, **params))
    return pd.concat(parts, ignore_index=True)


def granule_track_table(frames, method="gna", *, min_fragment=2, continuation="main", progress=False,
                        **params) -> pd.DataFrame:
    """One row per granule and frame: :func:`granalytics.granule_table`'s columns (size, volume,
    centre of mass, radius of gyration, liquid) with ``frame``, ``time_s`` and ``granule_track``,
    the id the granule keeps while it lives (the same as :func:`particle_table`'s with the same
    arguments, which are :func:`particle_table`'s)."""
    from granalytics.identification.granules import granule_table

    labels, tracks = granule_tracks(frames, method, min_fragment=min_fragment, continuation=continuation,
                                    progress=progress, **params)
    indices = _frame_indices(frames)
    parts = []
    for k, snapshot in enumerate(frames):
        table = granule_table(snapshot, labels[k]).reset_index()
        mapping = tracks.labels_to_tracks[k]
        table.insert(0, "granule_track", mapping[table["granule"].to_numpy()] if len(table) else np.zeros(0, np.int64))
        table.insert(0, "time_s", snapshot.time)
        table.insert(0, "frame", int(indices[k]))
        parts.append(table)
    return pd.concat(parts, ignore_index=True)
