"""Linking granules across frames into tracks, with their birth, death, coalescence and breakage
events (definitions in :func:`track_granules` and ``docs/tracking.md``): :func:`track_granules`
(labels and particle ids per frame) and :func:`track_run` (a run file), the frame after frame
loop over the steps of :mod:`.steps`, into the :class:`GranuleTracks` of :mod:`.tracks`.

Units: SI, time in seconds (``_s`` suffix); granule sizes in particles.
"""

from __future__ import annotations

import gc
from contextlib import contextmanager
from numbers import Integral

import numpy as np

from granalytics.analysis.tracking.steps import (aligned, smallest_ids, sorted_by_id, step_events,
                                                 step_fates, step_links, step_tracks)
from granalytics.analysis.tracking.tracks import GranuleTracks, events_table, tracks_table
from granalytics.base.errors import ParameterError
from granalytics.base.validation import FLAG, WINDOW, Array, Instance, Interval, Options, validate_params


#: Continuation rules of :func:`track_granules`: ``"main"`` (the main branch continues through
#: coalescence and breakage) and ``"strict"`` (every coalescence and breakage starts new tracks).
CONTINUATIONS = ("main", "strict")
#: the constraint of a ``continuation`` argument (:mod:`granalytics.base.validation`)
CONTINUATION = Options(CONTINUATIONS)
#: a sequence with one entry per frame
_PER_FRAME = Instance((list, tuple, np.ndarray), "a sequence with one entry per frame")


def _frames(labels_by_frame, ids_by_frame, times_s, min_fragment):
    """The checked frames of :func:`track_granules`: labels (negative ones -1) and ids as int64
    arrays, times [s] as floats."""
    labels_by_frame, ids_by_frame = list(labels_by_frame), list(ids_by_frame)
    times = np.asarray(times_s, dtype=float)
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


@validate_params({"labels_by_frame": [_PER_FRAME], "ids_by_frame": [_PER_FRAME], "times_s": [Array(ndim=1)],
                  "min_fragment": [Interval(Integral, 1, None)], "continuation": [CONTINUATION]})
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
    labels, ids, times = _frames(labels_by_frame, ids_by_frame, times_s, min_fragment)
    with _gc_paused():
        return _track(labels, ids, times, int(min_fragment), continuation)


def _track(labels, ids, times, m, continuation="strict"):
    """:func:`track_granules` on checked input (labels with −1 = free, int64 ids, times in s)."""
    sizes_by_frame = [_granule_sizes(lab) for lab in labels]
    # frame 0: one initial track per granule
    exists0 = sizes_by_frame[0] > 0
    next_track = int(exists0.sum())
    l2t = np.full(sizes_by_frame[0].size, -1, dtype=np.int64)
    l2t[exists0] = np.arange(next_track)
    labels_to_tracks = [l2t]
    origins = [np.zeros(next_track, dtype=np.int8)]
    ended_tracks, ended_codes, event_rows = [], [], []
    from_free, to_free = [np.zeros_like(sizes_by_frame[0])], []

    main = continuation == "main"
    prev_sorted = sorted_by_id(labels[0], ids[0], 0)
    first_b = smallest_ids(*prev_sorted, sizes_by_frame[0].size) if main else None
    for k in range(len(labels) - 1):
        cur_sorted = sorted_by_id(labels[k + 1], ids[k + 1], k + 1)
        la, lb = aligned(*prev_sorted, *cur_sorted)
        prev_sorted = cur_sorted
        first_a = first_b
        first_b = smallest_ids(*cur_sorted, sizes_by_frame[k + 1].size) if main else None
        sa, sb = sizes_by_frame[k], sizes_by_frame[k + 1]
        links = step_links(la, lb, sa.size, sb.size, m)
        to_free.append(links.to_free)
        from_free.append(links.from_free)
        fates = step_fates(links, sa, sb, first_a, first_b, main)
        ta = labels_to_tracks[k]
        tb, new_origins, ended = step_tracks(fates, ta, sb, next_track)
        next_track += new_origins.size
        origins.append(new_origins)
        labels_to_tracks.append(tb)
        for tracks_ending, codes in ended:
            ended_tracks.append(tracks_ending)
            ended_codes.append(codes)
        event_rows.extend(step_events(links, fates, ta, tb, sa, sb, k + 1))

    to_free.append(np.zeros_like(sizes_by_frame[-1]))
    events = events_table(times, event_rows)
    tracks = tracks_table(times, labels_to_tracks, sizes_by_frame, next_track, origins, ended_tracks, ended_codes)
    return GranuleTracks(events=events, tracks=tracks, labels_to_tracks=labels_to_tracks, times_s=times,
                         sizes_by_frame=sizes_by_frame, from_free_by_frame=from_free, to_free_by_frame=to_free,
                         min_fragment=m, continuation=continuation)


def _granule_sizes(labels):
    """Size of every granule label of one frame [particles] (0 for a label no particle carries)."""
    n_labels = int(labels.max()) + 1 if labels.size and labels.max() >= 0 else 0
    return np.bincount(labels[labels >= 0], minlength=n_labels).astype(np.int64)


@validate_params({"window": [WINDOW, None], "progress": [FLAG],
                  "min_fragment": [Interval(Integral, 1, None)], "continuation": [CONTINUATION], "return_labels": [FLAG]})
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
        if not hasattr(frames, "select"):
            raise ParameterError("track_run: window needs a Run or RunSlice (open_run), not a plain sequence of snapshots")
        frames = frames.select(revolutions=window)
    identifier = make_identifier(method, **params)
    indices, per_frame = map_frames(frames, lambda s: (identifier.identify(s).labels, s.ids, s.time),
                                    progress=progress, desc="track", what="track", jobs=jobs, scheduler=scheduler)
    labels, ids, times = (list(x) for x in zip(*per_frame))
    tracks = track_granules(labels, ids, times, min_fragment=min_fragment, continuation=continuation)
    tracks.frame_indices = indices
    return (labels, tracks) if return_labels else tracks

