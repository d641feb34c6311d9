"""Linking granules across frames into tracks, with their birth, death, coalescence and breakage
events (definitions in :func:`track_granules` and ``docs/tracking.md``): :class:`GranuleTracks`,
:func:`track_granules` (labels and particle ids per frame) and :func:`track_run` (a run file).

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles.
"""

from __future__ import annotations

import gc
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from granalytics.core.windows import check_interval
from granalytics.core.errors import ParameterError


#: Event kinds, in the order rows of one step are listed.
KINDS = ("birth", "death", "coalescence", "breakage")


_BIRTH, _DEATH, _COAL, _BREAK = range(4)


_ORIGINS = ("initial", "birth", "coalescence", "breakage")  # codes 0..3


_ENDS = ("alive", "death", "coalescence", "breakage")  # codes 0..3


_EVENT_COLUMNS = ("time_s", "frame", "kind", "parents", "children", "n_particles", "parent_sizes", "child_sizes")


_TRACK_COLUMNS = ("track", "first_time_s", "last_time_s", "first_frame", "last_frame", "sizes", "origin", "end")


#: Continuation rules of :func:`track_granules`: ``"main"`` (the main branch continues through
#: coalescence and breakage) and ``"strict"`` (every coalescence and breakage starts new tracks).
CONTINUATIONS = ("main", "strict")


def check_continuation(continuation) -> str:
    """``continuation`` if it is one of :data:`CONTINUATIONS`, else a one-line ParameterError."""
    if not isinstance(continuation, str) or continuation not in CONTINUATIONS:
        raise ParameterError(f"continuation must be 'main' or 'strict', got {continuation!r}")
    return continuation


def check_tracks(where, tracks) -> None:
    """Refuse (``ParameterError`` naming ``where``) anything but a :class:`GranuleTracks` (the
    result of :func:`track_granules` or :func:`track_run`)."""
    if not isinstance(tracks, GranuleTracks):
        raise ParameterError(f"{where}: tracks must be a GranuleTracks (track_run's or track_granules' result), got "
                             f"{type(tracks).__name__}")


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


def _check_frames(labels_by_frame, ids_by_frame, times_s, min_fragment):
    if isinstance(min_fragment, bool) or not isinstance(min_fragment, (int, np.integer)) or min_fragment < 1:
        raise ParameterError(f"min_fragment must be an integer >= 1, got {min_fragment!r}")
    for name, value in (("labels_by_frame", labels_by_frame), ("ids_by_frame", ids_by_frame), ("times_s", times_s)):
        if value is None or isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
            raise ParameterError(f"track_granules: {name} must be a sequence with one entry per frame, got "
                                 f"{type(value).__name__}")
    labels_by_frame, ids_by_frame = list(labels_by_frame), list(ids_by_frame)
    try:
        times = np.asarray(times_s, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ParameterError(f"track_granules: times_s must be numbers [s], got {str(times_s)[:40]!r}") from None
    n = len(labels_by_frame)
    if n == 0:
        raise ParameterError("no frames to track")
    most = max(np.size(labels) for labels in labels_by_frame)
    if min_fragment > most:
        raise ParameterError(f"min_fragment {min_fragment} is larger than the run's {most} particles: no coalescence or "
                             "breakage could ever be counted")
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


def track_granules(labels_by_frame, ids_by_frame, times_s, min_fragment=2, continuation="strict") -> GranuleTracks:
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
    continuation : {"strict", "main"}, default "strict"
        Which granule of frame k+1, if any, keeps the track id of a granule of frame k. The
        events are the same under both rules; only the track ids (and so the tracks) differ.

        - ``"strict"``: only a granule joined to its predecessor by the single link on both
          sides; every coalescence and every breakage ends its tracks and starts new ones (the
          definition of the kinetics, :func:`event_rates`, :func:`coalescence_kernel`).
        - ``"main"``: the main branch. Each granule a of frame k has a *main child*, the granule
          of k+1 that received most of its particles, and each granule b of k+1 a *main parent*,
          the granule of k that gave it most of its particles (links only, i.e. overlaps of at
          least ``min_fragment``); b continues a's track when each is the other's main one. A
          granule that sheds fragments keeps its id in the piece that kept most of it, and a
          coalescence continues the track of its largest contributor. Ties on the overlap go to
          the larger granule (the child's size at k+1, the parent's at k), then to the granule
          that holds the smaller particle id, so the ids do not depend on label values or row
          order. This is the default of the tables and exports (:func:`granalytics.particle_table`,
          :func:`granalytics.granule_track_table`, :func:`granalytics.export_vtk`).

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

    The events above, and the origins and ends, are those of ``continuation="strict"``. Under
    ``"main"`` the same events are recorded, but the granule that continues keeps its id: it is
    listed among the children of its breakage (with its parent's id) or among the parents of its
    coalescence (with its child's id). A main track therefore never ends by breakage: it ends by
    ``"death"``, or by ``"coalescence"`` when its main child continues another track; a track
    starts by ``"breakage"`` when it is a fragment that did not keep its parent's id, by
    ``"coalescence"`` when a coalescing granule continues no parent (its main parent's main
    child is another granule).

    The work per step is vectorised (sort-based contingency table, bincounts); Python loops run
    only over event rows to build their lists.
    """
    check_continuation(continuation)
    labels, ids, times = _check_frames(labels_by_frame, ids_by_frame, times_s, min_fragment)
    with _gc_paused():
        return _track(labels, ids, times, int(min_fragment), continuation)


def _smallest_ids(labels, ids, n_labels):
    """The smallest particle id of every granule label (int64 maximum for an unused label), from
    one frame's labels and ids sorted by id."""
    out = np.full(n_labels, np.iinfo(np.int64).max, dtype=np.int64)
    member = labels >= 0
    used, first = np.unique(labels[member], return_index=True)
    out[used] = ids[member][first]
    return out


def _main_links(src, dst, overlap, dst_size, dst_first, n_src):
    """For every granule of one side (``src`` labels of the links), the other side's granule of its
    main link: the most shared particles, then the larger ``dst`` granule, then the ``dst``
    granule holding the smaller particle id; −1 for a granule without links."""
    best = np.full(n_src, -1, dtype=np.int64)
    if src.size:
        order = np.lexsort((dst_first[dst], -dst_size[dst], -overlap, src))
        head = order[np.r_[True, src[order][1:] != src[order][:-1]]]
        best[src[head]] = dst[head]
    return best


def _track(labels, ids, times, m, continuation="strict"):
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

    main = continuation == "main"
    prev_sorted = _sorted_by_id(labels[0], ids[0], 0)
    first_b = _smallest_ids(*prev_sorted, sizes_by_frame[0].size) if main else None
    for k in range(n_frames - 1):
        cur_sorted = _sorted_by_id(labels[k + 1], ids[k + 1], k + 1)
        la, lb = _aligned(*prev_sorted, *cur_sorted)
        prev_sorted = cur_sorted
        first_a = first_b
        first_b = _smallest_ids(*cur_sorted, sizes_by_frame[k + 1].size) if main else None
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
        if main:  # b continues a when each is the other's main link
            ov = overlap[link]
            pred = _main_links(lb_link, la_link, ov, sa, first_a, gb)
            main_child = _main_links(la_link, lb_link, ov, sb, first_b, ga)
            has_pred = pred >= 0
            continuing = np.zeros(gb, dtype=bool)
            continuing[has_pred] = main_child[pred[has_pred]] == np.flatnonzero(has_pred)
            continued = np.zeros(ga, dtype=bool)
            continued[pred[continuing]] = True
            merged_away = ea & ~continued & ~dying  # its main child continues another track
            broken_end = np.zeros(ga, dtype=bool)
        else:
            pred = single_pred
            has_pred = pred >= 0
            child_of_break = np.zeros(gb, dtype=bool)
            child_of_break[has_pred] = breaking[pred[has_pred]]
            continuing = has_pred & ~child_of_break  # single link whose granule at k has a single link
            merged_away = np.zeros(ga, dtype=bool)
            has_succ = single_succ >= 0
            merged_away[has_succ] = coalescing[single_succ[has_succ]]
            broken_end = breaking

        # track ids at k+1: continuations inherit, every other granule starts a new track
        tb = np.full(gb, -1, dtype=np.int64)
        tb[continuing] = ta[pred[continuing]]
        new = eb & ~continuing
        n_new = int(new.sum())
        tb[new] = np.arange(next_track, next_track + n_new)
        next_track += n_new
        origin = np.where(coalescing, _ORIGINS.index("coalescence"),
                          np.where(born, _ORIGINS.index("birth"), _ORIGINS.index("breakage")))
        origins.append(origin[new].astype(np.int8))
        labels_to_tracks.append(tb)
        for mask, end in ((dying, "death"), (merged_away, "coalescence"), (broken_end, "breakage")):
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
                         min_fragment=m, continuation=continuation)


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


def track_run(frames, method="gna", window=None, progress=False, *, min_fragment=2, continuation="strict",
              return_labels=False, jobs=1, scheduler=None, **params):
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
    continuation : {"strict", "main"}, default "strict"
        Which granule keeps a track id through coalescence and breakage (:func:`track_granules`).
    return_labels : bool, default False
        Also return the granule labels of every frame.
    jobs, scheduler :
        Where the frames are analysed: ``jobs`` threads here, or a dask cluster (a scheduler's
        address or a ``distributed.Client``); see :func:`granalytics.analysis.frames.map_frames`.

    Returns
    -------
    GranuleTracks
        With ``frame_indices`` set to the frames' indices in the run file (positions in the
        sequence for a plain list of snapshots); with ``return_labels``, ``(labels, tracks)``:
        ``labels`` a list of (N,) int64 arrays, the granule of each particle in each frame (−1 free).
    """
    from granalytics.analysis.frames import map_frames
    from granalytics.identification import make_identifier

    if window is not None:
        window = check_interval("track_run: window", window)
        if not hasattr(frames, "select"):
            raise ParameterError("window needs a Run or RunSlice (open_run), not a plain sequence of snapshots")
        frames = frames.select(revolutions=window)
    check_continuation(continuation)  # before any frame is identified
    identifier = make_identifier(method, **params)
    indices, per_frame = map_frames(frames, lambda s: (identifier.identify(s).labels, s.ids, s.time),
                                    progress=progress, desc="track", what="track", jobs=jobs, scheduler=scheduler)
    labels, ids, times = (list(x) for x in zip(*per_frame))
    tracks = track_granules(labels, ids, times, min_fragment=min_fragment, continuation=continuation)
    tracks.frame_indices = indices
    return (labels, tracks) if return_labels else tracks

