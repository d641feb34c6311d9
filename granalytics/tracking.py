"""Granule life histories: tracking across frames, coalescence and breakage, population-balance rates.

Granules identified in successive frames are linked through the particles they share (particles
are matched by their *ids*, never by row). Every granule of every frame belongs to exactly one
*track*; a track starts at an ``"initial"`` granule (first frame), a ``"birth"``, a
``"coalescence"`` or a ``"breakage"``, and ends ``"alive"`` (last frame), by ``"death"``,
``"coalescence"`` or ``"breakage"``. The definitions are in :func:`track_granules` and in
``docs/tracking.md``.

From the events and the size histories, :func:`event_rates` gives event rates per revolution (or
per second), :func:`coalescence_kernel` the empirical coalescence kernel β(i, j) on logarithmic
size classes and :func:`breakage_rate` the selection (breakage) rate S(i), the two rate functions
of a population balance. :func:`tracking_figure` plots them; :func:`add_track_parser` and
:func:`cmd_track` are the ``granalytics track`` command.

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles.
"""

from __future__ import annotations

import gc
import math
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
import pandas as pd

from ._windows import window_tolerance
from .errors import ParameterError

__all__ = [
    "GranuleTracks", "KINDS", "track_granules", "track_run", "event_rates", "coalescence_kernel",
    "breakage_rate",
]

#: Event kinds, in the order rows of one step are listed.
KINDS = ("birth", "death", "coalescence", "breakage")
_BIRTH, _DEATH, _COAL, _BREAK = range(4)
_ORIGINS = ("initial", "birth", "coalescence", "breakage")  # codes 0..3
_ENDS = ("alive", "death", "coalescence", "breakage")  # codes 0..3

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


# --------------------------------------------------------------------------------------------
# tracking


def _check_frames(labels_by_frame, ids_by_frame, times_s, min_fragment):
    if isinstance(min_fragment, bool) or not isinstance(min_fragment, (int, np.integer)) or min_fragment < 1:
        raise ParameterError(f"min_fragment must be an integer >= 1, got {min_fragment!r}")
    labels_by_frame, ids_by_frame = list(labels_by_frame), list(ids_by_frame)
    times = np.asarray(times_s, dtype=float).reshape(-1)
    n = len(labels_by_frame)
    if n == 0:
        raise ParameterError("no frames to track")
    if len(ids_by_frame) != n or times.size != n:
        raise ParameterError(f"got {n} label arrays, {len(ids_by_frame)} id arrays and {times.size} times; "
                             "expected one of each per frame")
    if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
        raise ParameterError("times_s must be finite and strictly increasing")
    labels, ids = [], []
    for k, (lab, pid) in enumerate(zip(labels_by_frame, ids_by_frame)):
        lab = np.asarray(lab)
        pid = np.asarray(pid)
        if lab.ndim != 1 or pid.shape != lab.shape:
            raise ParameterError(f"frame {k}: labels {lab.shape} and ids {pid.shape} must be 1-D of equal length")
        if lab.size and not np.issubdtype(lab.dtype, np.integer):
            raise ParameterError(f"frame {k}: labels must be integers, got {lab.dtype}")
        if pid.size and not np.issubdtype(pid.dtype, np.integer):
            raise ParameterError(f"frame {k}: particle ids must be integers, got {pid.dtype}")
        lab = lab.astype(np.int64, copy=False)
        labels.append(np.where(lab < 0, -1, lab))
        ids.append(pid.astype(np.int64, copy=False))
    return labels, ids, times


def _sorted_by_id(labels, ids, k):
    """Labels of frame k in increasing id order, and the sorted ids (duplicate ids are an error)."""
    if ids.size < 2 or (ids[1:] > ids[:-1]).all():
        return labels, ids
    order = np.argsort(ids)
    sid = ids[order]
    if (sid[1:] == sid[:-1]).any():
        dup = sid[1:][sid[1:] == sid[:-1]][0]
        raise ParameterError(f"frame {k}: particle id {dup} occurs more than once")
    return labels[order], sid


def _aligned(la, ida, lb, idb):
    """Labels of two frames on the union of their particle ids (−1 where a particle is absent)."""
    if ida.shape == idb.shape and np.array_equal(ida, idb):
        return la, lb
    union = np.union1d(ida, idb)
    a = np.full(union.size, -1, dtype=np.int64)
    b = np.full(union.size, -1, dtype=np.int64)
    a[np.searchsorted(union, ida)] = la
    b[np.searchsorted(union, idb)] = lb
    return a, b


def _groups(keys, values):
    """Split ``values`` (already ordered by ``keys``) into Python lists, one per run of equal keys."""
    if keys.size == 0:
        return [], np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    ends = np.r_[starts[1:], keys.size]
    flat = values.tolist()
    return [flat[s:e] for s, e in zip(starts.tolist(), ends.tolist())], keys[starts]


@contextmanager
def _gc_paused():
    """Pause the cyclic garbage collector while building many small lists (none form cycles)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def track_granules(labels_by_frame, ids_by_frame, times_s, min_fragment=2) -> GranuleTracks:
    """Follow granules through a sequence of frames and find their births, deaths, coalescences
    and breakages.

    Parameters
    ----------
    labels_by_frame : sequence of (N_k,) int arrays
        Granule label of every particle in each frame (−1, or any negative value, = free), e.g.
        :attr:`IdentificationResult.labels`. Labels need not be contiguous; a label no particle
        carries is not a granule.
    ids_by_frame : sequence of (N_k,) int arrays
        Particle ids of the same rows. Particles are matched between frames by id, so rows may be
        in any order; a particle present in only one of two frames counts as free in the other.
    times_s : (K,) float array
        Time of each frame [s], strictly increasing.
    min_fragment : int, default 2
        The smallest number of particles that counts as a *fragment*: a coalescence needs at
        least this many particles from each of two or more granules, a breakage needs at least
        this many particles going to each of two or more granules. Smaller exchanges between
        granules are treated like exchanges with the free particles (layering and erosion).

    Returns
    -------
    GranuleTracks

    Notes
    -----
    For each step k → k+1 the contingency table ``C[a, b]`` (particles in granule a at k and
    in granule b at k+1) is built from the particles that are in a granule in both frames. A
    *link* a → b is an entry with ``C[a, b] >= min_fragment``. With ``out(a)`` the number of
    links leaving a and ``in(b)`` the number of links reaching b:

    - granule a of frame k ends by **breakage** if ``out(a) >= 2``, by **death** if
      ``out(a) == 0`` (every particle became free, or ``min_fragment == 1`` aside, it left in
      pieces smaller than ``min_fragment``), and by **coalescence** if its single link reaches a
      coalescing granule;
    - granule b of frame k+1 starts by **coalescence** if ``in(b) >= 2``, by **birth** if
      ``in(b) == 0`` (made of free particles, plus fewer than ``min_fragment`` particles from any
      one granule), and as a **breakage** child if its single link comes from a breaking granule;
    - otherwise a and b are joined by their single link (``out(a) == in(b) == 1``) and b
      *continues* a's track, whatever free particles it gained or lost (layering, erosion). The
      continued predecessor is therefore b's largest-overlap predecessor, and no granule is
      continued by two.

    A granule of k+1 can be a breakage child and a coalescence at once (a fragment of a breaking
    granule merges with another granule in the same step): it starts a track of origin
    ``"coalescence"``; it is listed among the children of the breakage event and is the child of
    the coalescence event, whose parents include the breaking granule. A granule that breaks
    ends with ``"breakage"`` even when some of its fragments coalesce.

    With ``min_fragment=1`` birth and death are literal: a birth is a granule made only of
    particles free at k, a death a granule whose particles are all free at k+1.

    The work per step is vectorised (sort-based contingency table, bincounts); Python loops run
    only over event rows to build their lists.
    """
    labels, ids, times = _check_frames(labels_by_frame, ids_by_frame, times_s, min_fragment)
    with _gc_paused():
        return _track(labels, ids, times, int(min_fragment))


def _track(labels, ids, times, m):
    """:func:`track_granules` on checked input (labels with −1 = free, int64 ids, times in s)."""
    n_frames = len(labels)

    sizes_by_frame = []
    for lab in labels:
        n_labels = int(lab.max()) + 1 if lab.size and lab.max() >= 0 else 0
        sizes_by_frame.append(np.bincount(lab[lab >= 0], minlength=n_labels).astype(np.int64))

    # frame 0: one initial track per granule
    exists0 = sizes_by_frame[0] > 0
    l2t = np.full(sizes_by_frame[0].size, -1, dtype=np.int64)
    l2t[exists0] = np.arange(int(exists0.sum()))
    labels_to_tracks = [l2t]
    next_track = int(exists0.sum())
    origins = [np.zeros(next_track, dtype=np.int8)]
    ended_tracks, ended_codes = [], []
    ev_kind, ev_frame, ev_parents, ev_children, ev_n, ev_psizes, ev_csizes = [], [], [], [], [], [], []
    from_free = [np.zeros_like(sizes_by_frame[0])]
    to_free = []

    prev_sorted = _sorted_by_id(labels[0], ids[0], 0)
    for k in range(n_frames - 1):
        cur_sorted = _sorted_by_id(labels[k + 1], ids[k + 1], k + 1)
        la, lb = _aligned(*prev_sorted, *cur_sorted)
        prev_sorted = cur_sorted
        sa, sb = sizes_by_frame[k], sizes_by_frame[k + 1]
        ta = labels_to_tracks[k]
        ga, gb = sa.size, sb.size
        ea, eb = sa > 0, sb > 0

        # contingency table of particles in granules at both frames: sorted unique (a, b) keys
        both = (la >= 0) & (lb >= 0)
        to_free.append(np.bincount(la[(la >= 0) & (lb < 0)], minlength=ga).astype(np.int64))
        from_free.append(np.bincount(lb[(lb >= 0) & (la < 0)], minlength=gb).astype(np.int64))
        keys, overlap = np.unique(la[both] * max(gb, 1) + lb[both], return_counts=True)
        pa, pb = keys // max(gb, 1), keys % max(gb, 1)
        link = overlap >= m
        la_link, lb_link = pa[link], pb[link]  # ordered by (a, b)
        out_deg = np.bincount(la_link, minlength=ga)
        in_deg = np.bincount(lb_link, minlength=gb)
        single_succ = np.full(ga, -1, dtype=np.int64)
        one = out_deg[la_link] == 1
        single_succ[la_link[one]] = lb_link[one]
        single_pred = np.full(gb, -1, dtype=np.int64)
        one = in_deg[lb_link] == 1
        single_pred[lb_link[one]] = la_link[one]

        breaking = ea & (out_deg >= 2)
        dying = ea & (out_deg == 0)
        coalescing = eb & (in_deg >= 2)
        born = eb & (in_deg == 0)
        has_pred = single_pred >= 0
        child_of_break = np.zeros(gb, dtype=bool)
        child_of_break[has_pred] = breaking[single_pred[has_pred]]
        continuing = has_pred & ~child_of_break  # single link whose granule at k has a single link
        merged_away = np.zeros(ga, dtype=bool)
        has_succ = single_succ >= 0
        merged_away[has_succ] = coalescing[single_succ[has_succ]]

        # track ids at k+1: continuations inherit, every other granule starts a new track
        tb = np.full(gb, -1, dtype=np.int64)
        tb[continuing] = ta[single_pred[continuing]]
        new = eb & ~continuing
        n_new = int(new.sum())
        tb[new] = np.arange(next_track, next_track + n_new)
        next_track += n_new
        origin = np.where(coalescing, _ORIGINS.index("coalescence"),
                          np.where(born, _ORIGINS.index("birth"), _ORIGINS.index("breakage")))
        origins.append(origin[new].astype(np.int8))
        labels_to_tracks.append(tb)
        for mask, end in ((dying, "death"), (merged_away, "coalescence"), (breaking, "breakage")):
            ended_tracks.append(ta[mask])
            ended_codes.append(np.full(int(mask.sum()), _ENDS.index(end), dtype=np.int8))

        # event rows of this step, in the order of KINDS, each ordered by label
        b_born = np.flatnonzero(born)
        a_dead = np.flatnonzero(dying)
        frame_rows = []
        frame_rows.append((_BIRTH, [[] for _ in b_born], [[t] for t in tb[b_born].tolist()],
                           sb[b_born], [[] for _ in b_born], [[s] for s in sb[b_born].tolist()]))
        frame_rows.append((_DEATH, [[t] for t in ta[a_dead].tolist()], [[] for _ in a_dead],
                           sa[a_dead], [[s] for s in sa[a_dead].tolist()], [[] for _ in a_dead]))
        # coalescence: links into coalescing granules, grouped by b (then ordered by a)
        into = coalescing[lb_link]
        order = np.lexsort((la_link[into], lb_link[into]))
        cb, ca = lb_link[into][order], la_link[into][order]
        parents, b_coal = _groups(cb, ta[ca])
        psizes, _ = _groups(cb, sa[ca])
        frame_rows.append((_COAL, parents, [[t] for t in tb[b_coal].tolist()], sb[b_coal], psizes,
                           [[s] for s in sb[b_coal].tolist()]))
        # breakage: links out of breaking granules, already ordered by (a, b)
        out = breaking[la_link]
        ba, bb = la_link[out], lb_link[out]
        children, a_break = _groups(ba, tb[bb])
        csizes, _ = _groups(ba, sb[bb])
        frame_rows.append((_BREAK, [[t] for t in ta[a_break].tolist()], children, sa[a_break],
                           [[s] for s in sa[a_break].tolist()], csizes))
        for kind, par, chi, n_part, ps, cs in frame_rows:
            ev_kind.append(np.full(len(par), kind, dtype=np.int8))
            ev_frame.append(np.full(len(par), k + 1, dtype=np.int64))
            ev_parents.extend(par)
            ev_children.extend(chi)
            ev_n.append(np.asarray(n_part, dtype=np.int64))
            ev_psizes.extend(ps)
            ev_csizes.extend(cs)

    to_free.append(np.zeros_like(sizes_by_frame[-1]))
    events = _events_table(times, ev_kind, ev_frame, ev_parents, ev_children, ev_n, ev_psizes, ev_csizes)
    tracks = _tracks_table(times, labels_to_tracks, sizes_by_frame, next_track, origins, ended_tracks, ended_codes)
    return GranuleTracks(events=events, tracks=tracks, labels_to_tracks=labels_to_tracks, times_s=times,
                         sizes_by_frame=sizes_by_frame, from_free_by_frame=from_free, to_free_by_frame=to_free,
                         min_fragment=m)


def _events_table(times, ev_kind, ev_frame, ev_parents, ev_children, ev_n, ev_psizes, ev_csizes):
    kind = np.concatenate(ev_kind) if ev_kind else np.zeros(0, dtype=np.int8)
    frame = np.concatenate(ev_frame) if ev_frame else np.zeros(0, dtype=np.int64)
    n_part = np.concatenate(ev_n) if ev_n else np.zeros(0, dtype=np.int64)
    return pd.DataFrame({
        "time_s": times[frame],
        "frame": frame,
        "kind": pd.Categorical.from_codes(kind, categories=list(KINDS)),
        "parents": pd.Series(ev_parents, dtype=object),
        "children": pd.Series(ev_children, dtype=object),
        "n_particles": n_part,
        "parent_sizes": pd.Series(ev_psizes, dtype=object),
        "child_sizes": pd.Series(ev_csizes, dtype=object),
    }, columns=list(_EVENT_COLUMNS))


def _tracks_table(times, labels_to_tracks, sizes_by_frame, n_tracks, origins, ended_tracks, ended_codes):
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
        "origin": pd.Categorical.from_codes(origin, categories=list(_ORIGINS)),
        "end": pd.Categorical.from_codes(end, categories=list(_ENDS)),
    }, columns=list(_TRACK_COLUMNS))


def track_run(frames, method="gna", window=None, progress=False, *, min_fragment=2, return_labels=False, **params):
    """Identify granules in every frame of a run and track them (:func:`track_granules`).

    Parameters
    ----------
    frames : Run, RunSlice or sequence of Snapshot
        For example ``open_run(path)``.
    method : str, default "gna"
        Identification method; ``params`` go to its constructor (e.g. ``c_agg=0.6``,
        ``a_agg_deg=20``, ``cohesion="acting"``).
    window : (float, float), optional
        Only frames within this closed interval of drum revolutions (needs a :class:`Run` or
        :class:`RunSlice`); default all frames.
    progress : bool, default False
        Show a progress bar over frames.
    min_fragment : int, default 2
        See :func:`track_granules`.
    return_labels : bool, default False
        Also return the granule labels of every frame.

    Returns
    -------
    GranuleTracks
        With ``frame_indices`` set to the frames' indices in the run file (positions in the
        sequence for a plain list of snapshots); with ``return_labels``, ``(labels, tracks)``:
        ``labels`` a list of (N,) int64 arrays, the granule of each particle in each frame (−1 free).
    """
    from .frames import map_frames
    from .identify import make_identifier

    if window is not None:
        if not hasattr(frames, "select"):
            raise ParameterError("window needs a Run or RunSlice (open_run), not a plain sequence of snapshots")
        frames = frames.select(revolutions=tuple(window))
    identifier = make_identifier(method, **params)
    indices, per_frame = map_frames(frames, lambda s: (identifier.identify(s).labels, s.ids, s.time),
                                    progress=progress, desc="track", what="track")
    labels, ids, times = (list(x) for x in zip(*per_frame))
    tracks = track_granules(labels, ids, times, min_fragment=min_fragment)
    tracks.frame_indices = indices
    return (labels, tracks) if return_labels else tracks


# --------------------------------------------------------------------------------------------
# rates


def _steps(tracks):
    t = np.asarray(tracks.times_s, dtype=float)
    if t.size < 2:
        raise ParameterError("rates need at least two tracked frames (one frame interval)")
    return t, np.diff(t)


def event_rates(tracks: GranuleTracks, revolution_period_s=None, *, bin_width=None) -> pd.DataFrame:
    """Event counts and rates per kind, binned in time.

    Each step k → k+1 (its events and its duration t_{k+1} − t_k) is assigned to the bin that
    holds the step's midpoint.

    Parameters
    ----------
    tracks : GranuleTracks
    revolution_period_s : float, optional
        Drum revolution period 2π/Ω [s]. Given: bins in revolutions and rates also per
        revolution. Not given: bins in seconds, rates per second only.
    bin_width : float, optional
        Bin width in revolutions (with a period; default 1) or in seconds (without; default a
        tenth of the tracked time span).

    Warns
    -----
    UserWarning
        When the frame intervals differ by more than 1.5× (rates of bins with other spacings
        are not comparable: events between frames further apart go uncounted).

    Returns
    -------
    DataFrame
        One row per (bin, kind), kinds in the order birth, death, coalescence, breakage.
        Columns ``bin``; ``rev_start``, ``rev_end`` (bin edges in revolutions, NaN without a
        period); ``time_start_s``, ``time_end_s`` [s]; ``observed_s`` (tracked time inside the
        bin [s]); ``kind``; ``count`` (events); ``rate_per_s`` (count / observed_s [1/s]);
        ``rate_per_rev`` (events per revolution, NaN without a period). Rates are NaN in a bin
        with no tracked time.
    """
    t, dt = _steps(tracks)
    if dt.max() > 1.5 * dt.min():
        warnings.warn(f"the tracked frames are {dt.min():.3g}–{dt.max():.3g} s apart (a run thinned outside a "
                      "window?): events between frames further apart go uncounted, so rates of bins with other "
                      "frame spacings are not comparable; track the evenly spaced part (--window)", stacklevel=2)
    if revolution_period_s is not None:
        period = float(revolution_period_s)
        if not (math.isfinite(period) and period > 0):
            raise ParameterError(f"revolution_period_s must be a positive number of seconds, got {revolution_period_s!r}")
        x = t / period
        width = 1.0 if bin_width is None else float(bin_width)
    else:
        period = None
        x = t
        width = (t[-1] - t[0]) / 10 if bin_width is None else float(bin_width)
    if not (math.isfinite(width) and width > 0):
        raise ParameterError(f"bin_width must be positive, got {bin_width!r}")
    # bin edges with the windows' tolerance: a first frame stamped 2.9999 revolutions opens the bin
    # [3, 4), not an empty [2, 3) (frames lie on whole time steps; granalytics._windows)
    tol = window_tolerance(x)
    start = math.floor((x[0] + tol) / width) * width
    n_bins = max(1, math.ceil((x[-1] - tol - start) / width - 1e-9))
    edges = start + width * np.arange(n_bins + 1)
    mid = (x[:-1] + x[1:]) / 2
    step_bin = np.clip(np.floor((mid - start) / width).astype(np.int64), 0, n_bins - 1)
    observed = np.bincount(step_bin, weights=dt, minlength=n_bins)
    ev = tracks.events
    kind_code = pd.Categorical(ev["kind"], categories=list(KINDS)).codes.astype(np.int64)
    ev_bin = step_bin[ev["frame"].to_numpy(dtype=np.int64) - 1]
    counts = np.bincount(ev_bin * len(KINDS) + kind_code, minlength=n_bins * len(KINDS)).reshape(n_bins, len(KINDS))
    with np.errstate(divide="ignore", invalid="ignore"):
        per_s = np.where(observed[:, None] > 0, counts / observed[:, None], np.nan)
    bins = np.repeat(np.arange(n_bins), len(KINDS))
    lo, hi = edges[:-1][bins], edges[1:][bins]
    table = pd.DataFrame({
        "bin": bins,
        "rev_start": lo if period else np.nan,
        "rev_end": hi if period else np.nan,
        "time_start_s": lo * period if period else lo,
        "time_end_s": hi * period if period else hi,
        "observed_s": observed[bins],
        "kind": pd.Categorical.from_codes(np.tile(np.arange(len(KINDS)), n_bins), categories=list(KINDS)),
        "count": counts.reshape(-1),
        "rate_per_s": per_s.reshape(-1),
        "rate_per_rev": per_s.reshape(-1) * period if period else np.nan,
    })
    return table


def _size_classes(tracks, size_bins, bins_per_decade):
    """Integer class edges (lower inclusive, upper exclusive) and a classifier."""
    if size_bins is not None:
        edges = np.asarray(size_bins)
        if edges.ndim != 1 or edges.size < 2 or not np.issubdtype(edges.dtype, np.number):
            raise ParameterError("size_bins must be at least two increasing integer edges")
        if (edges != np.round(edges)).any() or (np.diff(edges) <= 0).any() or edges[0] < 1:
            raise ParameterError(f"size_bins must be increasing integers >= 1, got {edges.tolist()}")
        edges = edges.astype(np.int64)
    else:
        if bins_per_decade <= 0:
            raise ParameterError(f"bins_per_decade must be positive, got {bins_per_decade!r}")
        all_sizes = np.concatenate([s[s > 0] for s in tracks.sizes_by_frame] + [np.zeros(0, np.int64)])
        lo = int(all_sizes.min()) if all_sizes.size else 2
        top = (int(all_sizes.max()) if all_sizes.size else lo) + 1
        n = max(1, math.ceil(bins_per_decade * math.log10(top / lo)))
        edges = np.unique(np.ceil(np.geomspace(lo, top, n + 1)).astype(np.int64))
        edges[0], edges[-1] = lo, max(edges[-1], top)

    def classify(sizes):
        sizes = np.asarray(sizes, dtype=np.int64)
        c = np.searchsorted(edges, sizes, side="right") - 1
        return np.where((c >= 0) & (c < edges.size - 1), c, -1)

    return edges, classify


def _mean_numbers(tracks, classify, n_classes, dt):
    """Time-averaged number of granules per class over the frames that start a step [granules]."""
    total = np.zeros(n_classes)
    for sizes, w in zip(tracks.sizes_by_frame[:-1], dt):
        c = classify(sizes[sizes > 0])
        total += w * np.bincount(c[c >= 0], minlength=n_classes)
    return total / dt.sum()


def coalescence_kernel(tracks: GranuleTracks, size_bins=None, *, bins_per_decade=4) -> pd.DataFrame:
    """Empirical coalescence kernel β(i, j) on logarithmic size classes.

    β(i, j) = r(i, j) / (N_i·N_j) for i ≠ j and r(i, i) / (N_i²/2) for i = j, where r(i, j) is
    the rate of binary coalescences between a granule of class i and one of class j [1/s] and
    N_i the time-averaged number of granules of class i (the number of distinct pairs is
    N_i·N_j, or N_i²/2 within a class, as in the Smoluchowski equation dN/dt = ½ΣβN_iN_j − …).

    Parent sizes are taken at the frame before the event. A coalescence of p parents counts as
    p − 1 binary coalescences, shared equally among its p(p−1)/2 parent pairs (weight 2/p each).
    N_i is averaged over the frames that start a step, weighted by the step's duration, from
    :attr:`GranuleTracks.sizes_by_frame` (the same numbers as the tracks' size histories); the
    rate divides by the tracked time t_K − t_0.

    Parameters
    ----------
    tracks : GranuleTracks
    size_bins : int array, optional
        Class edges in particles per granule, increasing; class i holds sizes
        ``size_bins[i] <= s < size_bins[i+1]``; sizes outside are ignored. Default: logarithmic
        classes of integers from the smallest to the largest tracked granule.
    bins_per_decade : float, default 4
        Classes per decade of size, for the default classes.

    Returns
    -------
    DataFrame
        One row per unordered pair of classes i <= j (empty cells included). Columns
        ``class_i``, ``class_j``; ``size_min_i``, ``size_max_i``, ``size_min_j``,
        ``size_max_j`` (inclusive bounds [particles]); ``n_events`` (coalescence events with a
        parent pair in the cell); ``n_pairs`` (parent pairs in the cell); ``n_binary`` (weighted
        binary coalescences); ``rate_per_s`` (n_binary / tracked time [1/s]); ``n_mean_i``,
        ``n_mean_j`` (time-averaged granule numbers); ``beta_per_s`` (β [1/s per pair of
        granules]; NaN where a class is never populated). Read β only where ``n_events`` is
        large enough: a cell with a handful of events is noise.
    """
    t, dt = _steps(tracks)
    edges, classify = _size_classes(tracks, size_bins, bins_per_decade)
    nc = edges.size - 1
    n_mean = _mean_numbers(tracks, classify, nc, dt)
    n_events = np.zeros((nc, nc))
    n_pairs = np.zeros((nc, nc))
    weight = np.zeros((nc, nc))
    coal = tracks.events.loc[tracks.events["kind"] == "coalescence", "parent_sizes"]
    for parent_sizes in coal:  # one iteration per coalescence event
        cls = classify(parent_sizes).tolist()
        p = len(cls)
        touched = set()
        for ci, cj in combinations(cls, 2):
            if ci < 0 or cj < 0:
                continue
            ci, cj = min(ci, cj), max(ci, cj)
            n_pairs[ci, cj] += 1
            weight[ci, cj] += 2.0 / p
            touched.add((ci, cj))
        for cell in touched:
            n_events[cell] += 1
    iu, ju = np.triu_indices(nc)
    rate = weight[iu, ju] / dt.sum()
    pairs = np.where(iu == ju, n_mean[iu] ** 2 / 2, n_mean[iu] * n_mean[ju])
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = np.where(pairs > 0, rate / pairs, np.nan)
    return pd.DataFrame({
        "class_i": iu, "class_j": ju,
        "size_min_i": edges[iu], "size_max_i": edges[iu + 1] - 1,
        "size_min_j": edges[ju], "size_max_j": edges[ju + 1] - 1,
        "n_events": n_events[iu, ju].astype(np.int64),
        "n_pairs": n_pairs[iu, ju].astype(np.int64),
        "n_binary": weight[iu, ju],
        "rate_per_s": rate,
        "n_mean_i": n_mean[iu], "n_mean_j": n_mean[ju],
        "beta_per_s": beta,
    })


def breakage_rate(tracks: GranuleTracks, size_bins=None, *, bins_per_decade=4) -> pd.DataFrame:
    """Empirical selection (breakage) rate S(i) on logarithmic size classes.

    S(i) = (breakage events of granules of class i per unit time) / N_i, with the size of the
    breaking granule at the frame before the event and N_i the time-averaged number of granules
    of class i (as in :func:`coalescence_kernel`).

    Parameters
    ----------
    tracks : GranuleTracks
    size_bins : int array, optional
        Class edges in particles per granule (see :func:`coalescence_kernel`).
    bins_per_decade : float, default 4

    Returns
    -------
    DataFrame
        One row per class: ``class``, ``size_min``, ``size_max`` (inclusive [particles]),
        ``n_events`` (breakages), ``fragments_mean`` (mean number of fragments, NaN without
        events), ``rate_per_s`` (n_events / tracked time [1/s]), ``n_mean`` (time-averaged
        number of granules), ``selection_rate_per_s`` (S(i) [1/s]; NaN where N_i = 0).
    """
    t, dt = _steps(tracks)
    edges, classify = _size_classes(tracks, size_bins, bins_per_decade)
    nc = edges.size - 1
    n_mean = _mean_numbers(tracks, classify, nc, dt)
    br = tracks.events[tracks.events["kind"] == "breakage"]
    c = classify(br["n_particles"].to_numpy(dtype=np.int64))
    n_children = np.fromiter((len(x) for x in br["children"]), dtype=np.int64, count=len(br))
    ok = c >= 0
    n_events = np.bincount(c[ok], minlength=nc)
    fragments = np.bincount(c[ok], weights=n_children[ok], minlength=nc)
    rate = n_events / dt.sum()
    with np.errstate(divide="ignore", invalid="ignore"):
        selection = np.where(n_mean > 0, rate / n_mean, np.nan)
        fragments_mean = np.where(n_events > 0, fragments / n_events, np.nan)
    return pd.DataFrame({
        "class": np.arange(nc),
        "size_min": edges[:-1], "size_max": edges[1:] - 1,
        "n_events": n_events.astype(np.int64),
        "fragments_mean": fragments_mean,
        "rate_per_s": rate,
        "n_mean": n_mean,
        "selection_rate_per_s": selection,
    })
