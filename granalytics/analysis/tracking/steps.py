"""One step k → k+1 of the tracking (:func:`granalytics.track_granules`): the particles of the
two frames matched by id, the links between their granules (the contingency table), which granule
continues which track under the continuation rule, and the step's event rows.

Granule sizes in particles; a granule is a label of its frame (−1: free).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from granalytics.analysis.tracking.tracks import BIRTH, BREAK, COAL, DEATH, ENDS, ORIGINS, EventRows
from granalytics.base.errors import ParameterError


def sorted_by_id(labels, ids, k):
    """Labels of frame k in increasing id order, and the sorted ids (duplicate ids are an error)."""
    if ids.size < 2 or (ids[1:] > ids[:-1]).all():
        return labels, ids
    order = np.argsort(ids)
    sid = ids[order]
    if (sid[1:] == sid[:-1]).any():
        dup = sid[1:][sid[1:] == sid[:-1]][0]
        raise ParameterError(f"frame {k}: particle id {dup} occurs more than once")
    return labels[order], sid


def aligned(la, ida, lb, idb):
    """Labels of two frames on the union of their particle ids (−1 where a particle is absent)."""
    if ida.shape == idb.shape and np.array_equal(ida, idb):
        return la, lb
    union = np.union1d(ida, idb)
    a = np.full(union.size, -1, dtype=np.int64)
    b = np.full(union.size, -1, dtype=np.int64)
    a[np.searchsorted(union, ida)] = la
    b[np.searchsorted(union, idb)] = lb
    return a, b


def smallest_ids(labels, ids, n_labels):
    """The smallest particle id of every granule label (int64 maximum for an unused label), from
    one frame's labels and ids sorted by id."""
    out = np.full(n_labels, np.iinfo(np.int64).max, dtype=np.int64)
    member = labels >= 0
    used, first = np.unique(labels[member], return_index=True)
    out[used] = ids[member][first]
    return out


class _Links(NamedTuple):
    """The links of one step: pairs (a at k, b at k+1) of granules sharing at least ``min_fragment``
    particles, ordered by (a, b)."""

    a: np.ndarray  # label at k of each link
    b: np.ndarray  # label at k+1 of each link
    overlap: np.ndarray  # particles each link shares
    out_deg: np.ndarray  # (G_k,) links leaving each granule of k
    in_deg: np.ndarray  # (G_k+1,) links reaching each granule of k+1
    to_free: np.ndarray  # (G_k,) particles of each granule of k free (or absent) at k+1
    from_free: np.ndarray  # (G_k+1,) particles of each granule of k+1 free (or absent) at k


def step_links(la, lb, ga, gb, m):
    """The :class:`_Links` of labels ``la`` (frame k, ``ga`` labels) and ``lb`` (frame k+1, ``gb``
    labels) aligned on the same particles: the contingency table of the particles in a granule in
    both frames, as sorted unique (a, b) keys, its entries of at least ``m`` particles kept."""
    both = (la >= 0) & (lb >= 0)
    to_free = np.bincount(la[(la >= 0) & (lb < 0)], minlength=ga).astype(np.int64)
    from_free = np.bincount(lb[(lb >= 0) & (la < 0)], minlength=gb).astype(np.int64)
    keys, overlap = np.unique(la[both] * max(gb, 1) + lb[both], return_counts=True)
    pa, pb = keys // max(gb, 1), keys % max(gb, 1)
    link = overlap >= m
    a, b = pa[link], pb[link]
    return _Links(a=a, b=b, overlap=overlap[link], out_deg=np.bincount(a, minlength=ga),
                  in_deg=np.bincount(b, minlength=gb), to_free=to_free, from_free=from_free)

class _Fates(NamedTuple):
    """How the granules of one step start (at k+1) and end (at k), as masks over their labels."""

    breaking: np.ndarray  # (G_k,) breaks: two or more links out
    dying: np.ndarray  # (G_k,) dies: no link out
    coalescing: np.ndarray  # (G_k+1,) coalescence: two or more links in
    born: np.ndarray  # (G_k+1,) birth: no link in
    pred: np.ndarray  # (G_k+1,) the granule of k whose track a continuing granule keeps (−1: none)
    continuing: np.ndarray  # (G_k+1,) keeps the track of ``pred``
    merged_away: np.ndarray  # (G_k,) its track ends by coalescence
    broken_end: np.ndarray  # (G_k,) its track ends by breakage


def step_fates(links, sa, sb, first_a, first_b, main):
    """The :class:`_Fates` of a step's granules (sizes ``sa`` at k, ``sb`` at k+1) from its
    ``links``, under the continuation rule ``"main"`` (``main``; ``first_a``, ``first_b``: the
    smallest particle id of each granule, for ties) or ``"strict"``."""
    ea, eb = sa > 0, sb > 0
    breaking = ea & (links.out_deg >= 2)
    dying = ea & (links.out_deg == 0)
    coalescing = eb & (links.in_deg >= 2)
    born = eb & (links.in_deg == 0)
    if main:
        pred, continuing, continued = _main_continuation(links, sa, sb, first_a, first_b)
        merged_away = ea & ~continued & ~dying  # its main child continues another track
        broken_end = np.zeros(sa.size, dtype=bool)
    else:
        pred, continuing, merged_away = _strict_continuation(links, sa.size, sb.size, breaking, coalescing)
        broken_end = breaking
    return _Fates(breaking=breaking, dying=dying, coalescing=coalescing, born=born, pred=pred, continuing=continuing,
                  merged_away=merged_away, broken_end=broken_end)


def _strict_continuation(links, ga, gb, breaking, coalescing):
    """``"strict"``: granule b of k+1 continues a of k when a → b is the single link of both; a's
    track ends by coalescence when its single link reaches a ``coalescing`` granule. Returns b's
    single predecessor (−1: none), the continuing b and the a that merge away."""
    single_succ = np.full(ga, -1, dtype=np.int64)
    one = links.out_deg[links.a] == 1
    single_succ[links.a[one]] = links.b[one]
    pred = np.full(gb, -1, dtype=np.int64)
    one = links.in_deg[links.b] == 1
    pred[links.b[one]] = links.a[one]
    has_pred = pred >= 0
    child_of_break = np.zeros(gb, dtype=bool)
    child_of_break[has_pred] = breaking[pred[has_pred]]
    continuing = has_pred & ~child_of_break  # single link whose granule at k has a single link
    merged_away = np.zeros(ga, dtype=bool)
    has_succ = single_succ >= 0
    merged_away[has_succ] = coalescing[single_succ[has_succ]]
    return pred, continuing, merged_away


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


def _main_continuation(links, sa, sb, first_a, first_b):
    """``"main"``: granule b of k+1 continues a of k when each is the other's main link
    (:func:`_main_links`). Returns b's main parent (−1: none), the continuing b and the continued a."""
    pred = _main_links(links.b, links.a, links.overlap, sa, first_a, sb.size)
    main_child = _main_links(links.a, links.b, links.overlap, sb, first_b, sa.size)
    has_pred = pred >= 0
    continuing = np.zeros(sb.size, dtype=bool)
    continuing[has_pred] = main_child[pred[has_pred]] == np.flatnonzero(has_pred)
    continued = np.zeros(sa.size, dtype=bool)
    continued[pred[continuing]] = True
    return pred, continuing, continued


def step_tracks(fates, ta, sb, next_track):
    """Track ids of the granules of k+1 (a continuing granule keeps its predecessor's id of ``ta``,
    every other granule gets a new one from ``next_track`` on, in label order), the origin codes
    of the new tracks, and the tracks of k that end with their end codes."""
    tb = np.full(sb.size, -1, dtype=np.int64)
    tb[fates.continuing] = ta[fates.pred[fates.continuing]]
    new = (sb > 0) & ~fates.continuing
    n_new = int(new.sum())
    tb[new] = np.arange(next_track, next_track + n_new)
    origin = np.where(fates.coalescing, ORIGINS.index("coalescence"),
                      np.where(fates.born, ORIGINS.index("birth"), ORIGINS.index("breakage")))
    ended = [(ta[mask], np.full(int(mask.sum()), ENDS.index(end), dtype=np.int8))
             for mask, end in ((fates.dying, "death"), (fates.merged_away, "coalescence"),
                               (fates.broken_end, "breakage"))]
    return tb, origin[new].astype(np.int8), ended

def _groups(keys, values):
    """Split ``values`` (already ordered by ``keys``) into Python lists, one per run of equal keys."""
    if keys.size == 0:
        return [], np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, keys[1:] != keys[:-1]])
    ends = np.r_[starts[1:], keys.size]
    flat = values.tolist()
    return [flat[s:e] for s, e in zip(starts.tolist(), ends.tolist())], keys[starts]


def step_events(links, fates, ta, tb, sa, sb, frame):
    """The :class:`EventRows` of step ``frame − 1`` → ``frame``, one per kind in the order of
    :data:`KINDS`: track ids ``ta`` and sizes ``sa`` of the granules of k, ``tb`` and ``sb`` of
    those of k+1."""
    b_born = np.flatnonzero(fates.born)
    a_dead = np.flatnonzero(fates.dying)
    rows = [EventRows(frame, BIRTH, [[] for _ in b_born], [[t] for t in tb[b_born].tolist()], sb[b_born],
                       [[] for _ in b_born], [[s] for s in sb[b_born].tolist()]),
            EventRows(frame, DEATH, [[t] for t in ta[a_dead].tolist()], [[] for _ in a_dead], sa[a_dead],
                       [[s] for s in sa[a_dead].tolist()], [[] for _ in a_dead])]
    # coalescence: links into coalescing granules, grouped by b (then ordered by a)
    into = fates.coalescing[links.b]
    order = np.lexsort((links.a[into], links.b[into]))
    cb, ca = links.b[into][order], links.a[into][order]
    parents, b_coal = _groups(cb, ta[ca])
    psizes, _ = _groups(cb, sa[ca])
    rows.append(EventRows(frame, COAL, parents, [[t] for t in tb[b_coal].tolist()], sb[b_coal], psizes,
                           [[s] for s in sb[b_coal].tolist()]))
    # breakage: links out of breaking granules, already ordered by (a, b)
    out = fates.breaking[links.a]
    ba, bb = links.a[out], links.b[out]
    children, a_break = _groups(ba, tb[bb])
    csizes, _ = _groups(ba, sb[bb])
    rows.append(EventRows(frame, BREAK, [[t] for t in ta[a_break].tolist()], children, sa[a_break],
                           [[s] for s in sa[a_break].tolist()], csizes))
    return rows
