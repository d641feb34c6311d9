"""The result of the tracking: :class:`GranuleTracks` (events and tracks of a sequence of
frames), the event kinds (:data:`KINDS`) and the tables built from the steps of
:func:`granalytics.track_granules`.

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import pandas as pd

from granalytics.base.validation import Instance


#: Event kinds, in the order rows of one step are listed.
KINDS = ("birth", "death", "coalescence", "breakage")


BIRTH, DEATH, COAL, BREAK = range(4)


ORIGINS = ("initial", "birth", "coalescence", "breakage")  # codes 0..3


ENDS = ("alive", "death", "coalescence", "breakage")  # codes 0..3


_EVENT_COLUMNS = ("time_s", "frame", "kind", "parents", "children", "n_particles", "parent_sizes", "child_sizes")


_TRACK_COLUMNS = ("track", "first_time_s", "last_time_s", "first_frame", "last_frame", "sizes", "origin", "end")


@dataclass(eq=False)
class GranuleTracks:
    """Granule tracks and events of a sequence of frames (output of :func:`track_granules`).

    Attributes
    ----------
    events : DataFrame
        One row per event, ordered by frame, then kind (birth, death, coalescence, breakage), then
        label. Columns:

        - ``time_s`` [s]: time of the later frame of the step k → k+1 in which it happened;
        - ``frame``: index of that later frame (k+1) in the tracked sequence;
        - ``kind``: ``"birth"``, ``"death"``, ``"coalescence"`` or ``"breakage"``;
        - ``parents``, ``children``: lists of track ids (granules at k that took part; granules
          at k+1 that resulted). Birth: no parents, one child; death: one parent, no child;
          coalescence: ≥ 2 parents, one child; breakage: one parent, ≥ 2 children;
        - ``n_particles``: size of the resulting granule (birth, coalescence: at k+1) or of the
          one that ends (death, breakage: at k) [particles];
        - ``parent_sizes``, ``child_sizes``: lists of the sizes of the parents at k and of the
          children at k+1, in the order of ``parents`` and ``children`` [particles].
    tracks : DataFrame
        One row per track, ordered by track id. Columns ``track`` (id, 0, 1, … in order of
        creation), ``first_time_s``, ``last_time_s`` [s], ``first_frame``, ``last_frame``,
        ``sizes`` (list: the granule's size in every frame of its life, first to last
        [particles]), ``origin`` (``"initial"``, ``"birth"``, ``"coalescence"``,
        ``"breakage"``) and ``end`` (``"alive"``, ``"death"``, ``"coalescence"``,
        ``"breakage"``).
    labels_to_tracks : list of (G_k,) int64 arrays
        Per frame, the track id of each granule label (−1 for a label no particle carries).
    times_s : (K,) float array
        Time of each frame [s].
    sizes_by_frame : list of (G_k,) int64 arrays
        Per frame, the size of each granule label [particles] (0 for unused labels).
    from_free_by_frame : list of (G_k,) int64 arrays
        Per frame k, for each label, the particles of that granule that were free (or absent) at
        frame k−1 (layering; zeros in the first frame).
    to_free_by_frame : list of (G_k,) int64 arrays
        Per frame k, for each label, the particles of that granule that are free (or absent) at
        frame k+1 (erosion; zeros in the last frame).
    min_fragment : int
        The ``min_fragment`` the tracking used.
    continuation : {"strict", "main"}
        The continuation rule the tracking used (:func:`track_granules`): it decides which
        granules keep a track id, hence ``tracks``, ``labels_to_tracks`` and the ids in
        ``events``; every other attribute, and every event but its ids, is the same under both.
    frame_indices : (K,) int array or None
        For :func:`track_run`, the index of each tracked frame in the run file.
    """

    events: pd.DataFrame
    tracks: pd.DataFrame
    labels_to_tracks: list
    times_s: np.ndarray
    sizes_by_frame: list = field(repr=False)
    from_free_by_frame: list = field(repr=False)
    to_free_by_frame: list = field(repr=False)
    min_fragment: int = 2
    continuation: str = "strict"
    frame_indices: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        """Number of tracked frames K."""
        return int(len(self.times_s))

    @property
    def n_tracks(self) -> int:
        """Number of tracks."""
        return int(len(self.tracks))

    def event_counts(self) -> pd.Series:
        """Number of events of each kind (all four kinds, zeros included)."""
        return self.events["kind"].value_counts().reindex(list(KINDS), fill_value=0).astype(int)


#: the constraint of a ``tracks`` argument (:mod:`granalytics.base.validation`)
TRACKS = Instance(GranuleTracks, "a GranuleTracks (track_run's or track_granules' result)")


class EventRows(NamedTuple):
    """The events of one kind in one step k → k+1: lists with one entry per event, ordered by label."""

    frame: int  # k+1
    kind: int  # code: position in KINDS
    parents: list  # track ids of the parents (granules at k) of each event
    children: list  # track ids of the children (granules at k+1)
    n_particles: np.ndarray  # size of the resulting (birth, coalescence) or ending (death, breakage) granule
    parent_sizes: list
    child_sizes: list


def events_table(times, rows):
    """The events table of :class:`GranuleTracks` from a list of :class:`EventRows`."""
    if rows:
        kind = np.concatenate([np.full(len(r.parents), r.kind, dtype=np.int8) for r in rows])
        frame = np.concatenate([np.full(len(r.parents), r.frame, dtype=np.int64) for r in rows])
        n_part = np.concatenate([np.asarray(r.n_particles, dtype=np.int64) for r in rows])
    else:
        kind, frame, n_part = np.zeros(0, dtype=np.int8), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    return pd.DataFrame({
        "time_s": times[frame],
        "frame": frame,
        "kind": pd.Categorical.from_codes(kind, categories=list(KINDS)),
        "parents": pd.Series([p for r in rows for p in r.parents], dtype=object),
        "children": pd.Series([c for r in rows for c in r.children], dtype=object),
        "n_particles": n_part,
        "parent_sizes": pd.Series([s for r in rows for s in r.parent_sizes], dtype=object),
        "child_sizes": pd.Series([s for r in rows for s in r.child_sizes], dtype=object),
    }, columns=list(_EVENT_COLUMNS))


def tracks_table(times, labels_to_tracks, sizes_by_frame, n_tracks, origins, ended_tracks, ended_codes):
    # every (track, frame, size) of every granule, grouped by track in frame order
    track_of, frame_of, size_of = [], [], []
    for k, (tk, sk) in enumerate(zip(labels_to_tracks, sizes_by_frame)):
        used = tk >= 0
        track_of.append(tk[used])
        frame_of.append(np.full(int(used.sum()), k, dtype=np.int64))
        size_of.append(sk[used])
    track_of, frame_of, size_of = (np.concatenate(x) for x in (track_of, frame_of, size_of))
    order = np.argsort(track_of, kind="stable")
    frame_of, size_of = frame_of[order], size_of[order]
    length = np.bincount(track_of, minlength=n_tracks)
    ends = np.cumsum(length)
    starts = ends - length
    flat = size_of.tolist()
    sizes = [flat[s:e] for s, e in zip(starts.tolist(), ends.tolist())]
    first = frame_of[starts] if n_tracks else np.zeros(0, dtype=np.int64)
    last = frame_of[ends - 1] if n_tracks else np.zeros(0, dtype=np.int64)
    end = np.zeros(n_tracks, dtype=np.int8)
    if ended_tracks:
        end[np.concatenate(ended_tracks)] = np.concatenate(ended_codes)
    origin = np.concatenate(origins) if origins else np.zeros(0, dtype=np.int8)
    return pd.DataFrame({
        "track": np.arange(n_tracks, dtype=np.int64),
        "first_time_s": times[first],
        "last_time_s": times[last],
        "first_frame": first,
        "last_frame": last,
        "sizes": pd.Series(sizes, dtype=object),
        "origin": pd.Categorical.from_codes(origin, categories=list(ORIGINS)),
        "end": pd.Categorical.from_codes(end, categories=list(ENDS)),
    }, columns=list(_TRACK_COLUMNS))

