"""Granule tracking: planted events, invariances, consistency with identification, rates, CLI."""

import argparse
import json
import math

import numpy as np
import pandas as pd
import pytest

import granalytics as ga
from granalytics.base.errors import ParameterError
from granalytics.datasets.synthetic import synthetic_snapshot, write_synthetic_run
from granalytics.analysis.tracking import (
    KINDS,
    breakage_rate,
    coalescence_kernel,
    event_rates,
    kernel_matrix,
    rate_errors,
    size_histories,
    track_granules,
    track_run,
)
from granalytics.cli.tracking import add_track_parser
from granalytics.report.figures import tracking_figure


def frame(granules, ids, rng=None):
    """Labels and ids of one frame: ``granules`` is a list of particle-id lists (label = position),
    ``ids`` every particle id present; rows are shuffled when ``rng`` is given."""
    ids = np.asarray(ids, dtype=np.int64)
    labels = np.full(ids.size, -1, dtype=np.int64)
    where = {pid: row for row, pid in enumerate(ids.tolist())}
    for g, members in enumerate(granules):
        labels[[where[p] for p in members]] = g
    if rng is not None:
        order = rng.permutation(ids.size)
        labels, ids = labels[order], ids[order]
    return labels, ids


def track(frames, times=None, **kw):
    labels, ids = zip(*frames)
    times = np.arange(len(frames), dtype=float) if times is None else times
    return track_granules(labels, ids, times, **kw)


def events_of(tracks, kind):
    return tracks.events[tracks.events["kind"] == kind]


def track_of(tracks, frame_index, label):
    return int(tracks.labels_to_tracks[frame_index][label])


def check_consistency(tr):
    """Tracks and events agree: every started track is the child of one event of its origin kind,
    every ended track the parent of one event of its end kind, and the size histories are the
    per-frame granule sizes."""
    tracks = tr.tracks.set_index("track")
    as_child = {t: [] for t in tracks.index}
    as_parent = {t: [] for t in tracks.index}
    for row in tr.events.itertuples():
        for t in row.children:
            as_child[t].append(row.kind)
        for t in row.parents:
            as_parent[t].append(row.kind)
    for t, row in tracks.iterrows():
        assert len(row.sizes) == row.last_frame - row.first_frame + 1
        assert row.first_time_s == tr.times_s[row.first_frame] and row.last_time_s == tr.times_s[row.last_frame]
        # a coalescence may merge fragments of breaking granules: it is also a child of those breakages
        expected_child = {"initial": [], "birth": ["birth"], "breakage": ["breakage"]}.get(row.origin)
        if expected_child is None:
            assert as_child[t].count("coalescence") == 1 and set(as_child[t]) <= {"coalescence", "breakage"}
        else:
            assert as_child[t] == expected_child
        # a granule that breaks is also a parent of every coalescence one of its fragments enters
        expected_parent = {"alive": [], "death": ["death"], "coalescence": ["coalescence"]}.get(row.end)
        if expected_parent is None:
            assert as_parent[t].count("breakage") == 1 and set(as_parent[t]) <= {"coalescence", "breakage"}
        else:
            assert as_parent[t] == expected_parent
    for k, (l2t, sizes) in enumerate(zip(tr.labels_to_tracks, tr.sizes_by_frame)):
        assert (l2t >= 0).sum() == (sizes > 0).sum()
        for label in np.flatnonzero(sizes):
            row = tracks.loc[l2t[label]]
            assert row.first_frame <= k <= row.last_frame and row.sizes[k - row.first_frame] == sizes[label]


# ----------------------------------------------------------------------------------------------
# planted events


def test_every_kind_planted_with_reordered_rows():
    rng = np.random.default_rng(1)
    A, B, C, D, E = range(6), range(6, 10), range(10, 18), [18, 19, 20], range(21, 25)
    ids0 = np.arange(40)
    ids1 = np.r_[0:18, 21:40, 40]  # D's particles left the system; particle 40 is new
    f0 = frame([A, B, C, D, E], ids0, rng)
    # A+B coalesce, C breaks into two, D dies, E layers (+30), F = {35, 36, 40} is born
    f1 = frame([[*A, *B], [10, 11, 12, 13], [14, 15, 16, 17], [21, 22, 23, 24, 30], [35, 36, 40]], ids1, rng)
    # E erodes (−21) and layers (+31, +32); the rest continue
    f2 = frame([[*A, *B], [10, 11, 12, 13], [14, 15, 16, 17], [22, 23, 24, 30, 31, 32], [35, 36, 40]], ids1, rng)
    tr = track([f0, f1, f2], times=np.array([0.0, 0.5, 1.25]))

    assert tr.event_counts().to_dict() == {"birth": 1, "death": 1, "coalescence": 1, "breakage": 1}
    ev = tr.events
    assert (ev["frame"] == 1).all() and (ev["time_s"] == 0.5).all()
    assert list(ev["kind"]) == list(KINDS)  # one step: rows in the order of KINDS
    t0 = [track_of(tr, 0, g) for g in range(5)]
    t1 = [track_of(tr, 1, g) for g in range(5)]
    birth, death, coal, brk = (ev.iloc[i] for i in range(4))
    assert birth["parents"] == [] and birth["children"] == [t1[4]] and birth["n_particles"] == 3
    assert death["parents"] == [t0[3]] and death["children"] == [] and death["n_particles"] == 3
    assert coal["parents"] == [t0[0], t0[1]] and coal["children"] == [t1[0]] and coal["n_particles"] == 10
    assert coal["parent_sizes"] == [6, 4] and coal["child_sizes"] == [10]
    assert brk["parents"] == [t0[2]] and brk["children"] == [t1[1], t1[2]] and brk["n_particles"] == 8
    assert brk["child_sizes"] == [4, 4]

    tracks = tr.tracks.set_index("track")
    assert t1[3] == t0[4] and tracks.loc[t0[4], "sizes"] == [4, 5, 6]  # E continues through both steps
    assert tracks.loc[t0[4], ["origin", "end", "first_frame", "last_frame"]].tolist() == ["initial", "alive", 0, 2]
    assert [tracks.loc[t, "end"] for t in t0] == ["coalescence", "coalescence", "breakage", "death", "alive"]
    assert [tracks.loc[t, "origin"] for t in t1] == ["coalescence", "breakage", "breakage", "initial", "birth"]
    assert tracks.loc[t1[0], "sizes"] == [10, 10] and tracks.loc[t1[0], "last_time_s"] == 1.25
    assert [track_of(tr, 2, g) for g in range(5)] == t1
    assert tr.n_tracks == 9
    check_consistency(tr)


def test_breakage_child_that_coalesces_in_the_same_step():
    # P breaks: half stays alone (Y), half merges with Q (X)
    P, Q = range(8), range(8, 12)
    ids = np.arange(20)
    tr = track([frame([P, Q], ids), frame([[0, 1, 2, 3, *Q], [4, 5, 6, 7]], ids)])
    (tp, tq), (tx, ty) = tr.labels_to_tracks
    brk, coal = events_of(tr, "breakage").iloc[0], events_of(tr, "coalescence").iloc[0]
    assert brk["parents"] == [tp] and brk["children"] == [tx, ty]
    assert coal["parents"] == [tp, tq] and coal["children"] == [tx] and coal["parent_sizes"] == [8, 4]
    tracks = tr.tracks.set_index("track")
    assert tracks.loc[tp, "end"] == "breakage" and tracks.loc[tq, "end"] == "coalescence"
    assert tracks.loc[tx, "origin"] == "coalescence" and tracks.loc[ty, "origin"] == "breakage"
    assert len(tr.events) == 2
    check_consistency(tr)


def test_simultaneous_events_in_one_step_are_all_recorded():
    # two coalescences, two breakages, two births, two deaths in one step
    ids = np.arange(100)
    g0 = [range(0, 4), range(4, 8), range(10, 14), range(14, 18), range(20, 26), range(30, 36), [40, 41], [50, 51, 52]]
    g1 = [range(0, 8), range(10, 18), range(20, 23), range(23, 26), range(30, 32), range(32, 34), range(34, 36),
          [60, 61], [70, 71, 72]]
    tr = track([frame(g0, ids, np.random.default_rng(2)), frame(g1, ids, np.random.default_rng(3))])
    assert tr.event_counts().to_dict() == {"birth": 2, "death": 2, "coalescence": 2, "breakage": 2}
    assert [len(c) for c in events_of(tr, "breakage")["children"]] == [2, 3]
    assert events_of(tr, "death")["n_particles"].tolist() == [2, 3]
    check_consistency(tr)


def test_granule_losing_and_gaining_particles_continues_with_its_size_history():
    ids = np.arange(40)
    A, B = list(range(10)), list(range(10, 20))
    # A loses 0 (free) and gains 10 (from B, one particle < min_fragment) and 30, 31 (free);
    # B loses 10 and gains 0 (one from A): exchanges below min_fragment are layering/erosion
    f1 = frame([[*range(1, 10), 10, 30, 31], [*range(11, 20), 0]], ids)
    f2 = frame([[*range(1, 10), 10, 30, 31, 32], range(11, 20)], ids)
    tr = track([frame([A, B], ids), f1, f2])
    assert len(tr.events) == 0
    assert tr.tracks["sizes"].tolist() == [[10, 12, 13], [10, 10, 9]]
    # layering (particles that were free) and erosion (particles that become free) per label
    assert [x.tolist() for x in tr.from_free_by_frame] == [[0, 0], [2, 0], [1, 0]]
    assert [x.tolist() for x in tr.to_free_by_frame] == [[0, 0], [0, 1], [0, 0]]
    assert (tr.tracks["origin"] == "initial").all() and (tr.tracks["end"] == "alive").all()


def test_min_fragment_is_respected():
    ids = np.arange(40)
    A = list(range(10))
    # A gives one particle to a granule otherwise made of free particles
    f0, f1 = frame([A], ids), frame([range(9), [9, 20, 21]], ids)
    two = track([f0, f1], min_fragment=2)
    assert two.event_counts().to_dict() == {"birth": 1, "death": 0, "coalescence": 0, "breakage": 0}
    assert two.tracks["sizes"].iloc[0] == [10, 9]
    one = track([f0, f1], min_fragment=1)
    assert one.event_counts().to_dict() == {"birth": 0, "death": 0, "coalescence": 0, "breakage": 1}
    # a small granule S that sends one particle into A (the other becomes free)
    f0, f1 = frame([A, [10, 11]], ids), frame([[*A, 10]], ids)
    two = track([f0, f1], min_fragment=2)
    assert two.event_counts().to_dict() == {"birth": 0, "death": 1, "coalescence": 0, "breakage": 0}
    assert two.tracks["sizes"].iloc[0] == [10, 11]
    one = track([f0, f1], min_fragment=1)
    assert one.event_counts().to_dict() == {"birth": 0, "death": 0, "coalescence": 1, "breakage": 0}
    # a larger threshold turns a 2 + 2 coalescence into continuation plus death
    f0, f1 = frame([range(5), [10, 11]], ids), frame([[*range(5), 10, 11]], ids)
    assert track([f0, f1], min_fragment=2).event_counts()["coalescence"] == 1
    three = track([f0, f1], min_fragment=3)
    assert three.event_counts().to_dict() == {"birth": 0, "death": 1, "coalescence": 0, "breakage": 0}


def random_series(n_frames=8, n=400, seed=0):
    """Labels with persistence: each step 30 % of the particles take a random active label or
    become free, one active label dissolves and one new label forms from free particles; ids are
    offset and about 5 % of the particles are missing in each frame."""
    rng = np.random.default_rng(seed)
    active = list(range(30))
    base = rng.choice(np.r_[-1, active], n)
    next_label = 30
    labels, ids = [], []
    for k in range(n_frames):
        if k:
            change = rng.random(n) < 0.3
            base = np.where(change, rng.choice(np.r_[-1, active], n), base)
            gone = active.pop(int(rng.integers(len(active))))
            base[base == gone] = -1
            free = np.flatnonzero(base == -1)
            base[rng.choice(free, 6, replace=False)] = next_label
            active.append(next_label)
            next_label += 1
        present = rng.random(n) > 0.05
        labels.append(base[present].copy())
        ids.append(1000 + np.flatnonzero(present))
    return labels, ids


def test_invariant_to_row_order_and_consistent():
    labels, ids = random_series()
    times = np.linspace(0.0, 1.4, len(labels))
    ref = track_granules(labels, ids, times)
    assert set(ref.events["kind"]) == set(KINDS)
    check_consistency(ref)
    rng = np.random.default_rng(5)
    orders = [rng.permutation(lab.size) for lab in labels]
    shuffled = track_granules([lab[o] for lab, o in zip(labels, orders)], [i[o] for i, o in zip(ids, orders)], times)
    pd.testing.assert_frame_equal(ref.events, shuffled.events)
    pd.testing.assert_frame_equal(ref.tracks, shuffled.tracks)
    for a, b in zip(ref.labels_to_tracks, shuffled.labels_to_tracks):
        assert np.array_equal(a, b)


def test_input_errors():
    ids = np.arange(4)
    lab = np.array([0, 0, -1, -1])
    with pytest.raises(ParameterError, match="min_fragment"):
        track_granules([lab, lab], [ids, ids], [0, 1], min_fragment=0)
    with pytest.raises(ParameterError, match="increasing"):
        track_granules([lab, lab], [ids, ids], [1, 1])
    with pytest.raises(ParameterError, match="more than once"):
        track_granules([lab, lab], [ids, np.array([0, 1, 1, 3])], [0, 1])
    with pytest.raises(ParameterError, match="equal length"):
        track_granules([lab, lab[:3]], [ids, ids], [0, 1])
    single = track_granules([lab], [ids], [0.0])
    assert single.n_tracks == 1 and len(single.events) == 0 and single.tracks["end"].iloc[0] == "alive"
    with pytest.raises(ParameterError, match="two tracked frames"):
        event_rates(single)


# ----------------------------------------------------------------------------------------------
# continuation rules: the main branch keeps its id, the events stay the same


def granule_events(tr):
    """The events table with each track id replaced by the granule it names: (frame, label) of
    the parents at the frame before the event and of the children at the event's frame."""
    def granules(tracks, frame_index):
        l2t = tr.labels_to_tracks[frame_index]
        return [(frame_index, int(np.flatnonzero(l2t == t)[0])) for t in tracks]

    ev = tr.events.copy()
    ev["parents"] = [granules(p, f - 1) for p, f in zip(ev["parents"], ev["frame"])]
    ev["children"] = [granules(c, f) for c, f in zip(ev["children"], ev["frame"])]
    return ev


def check_same_events(strict, main):
    """The same events (kind, frame, sizes, and parents and children as granules) under both rules,
    hence the same rates, kernel and selection rate."""
    assert strict.continuation == "strict" and main.continuation == "main"
    pd.testing.assert_frame_equal(granule_events(strict), granule_events(main))
    ids = ["parents", "children"]
    pd.testing.assert_frame_equal(strict.events.drop(columns=ids), main.events.drop(columns=ids))
    for rate in (lambda t: event_rates(t, revolution_period_s=2.0), coalescence_kernel, breakage_rate):
        pd.testing.assert_frame_equal(rate(strict), rate(main))


def check_main_tracks(tr):
    """Main-branch tracks: the size histories are the per-frame sizes, a track is continued only
    along a link in which each granule is the other's main one, and a continuing granule's id is
    among the parents of its coalescence or the children of its breakage."""
    tracks = tr.tracks.set_index("track")
    assert "breakage" not in set(tracks["end"])
    for k, (l2t, sizes) in enumerate(zip(tr.labels_to_tracks, tr.sizes_by_frame)):
        assert (l2t >= 0).sum() == (sizes > 0).sum() and len(set(l2t[l2t >= 0])) == (sizes > 0).sum()
        for label in np.flatnonzero(sizes):
            row = tracks.loc[l2t[label]]
            assert row.first_frame <= k <= row.last_frame and row.sizes[k - row.first_frame] == sizes[label]
    for row in tr.events.itertuples():
        if row.kind == "coalescence" and row.children[0] in row.parents:
            assert tracks.loc[row.children[0], "first_frame"] < row.frame
        if row.kind == "breakage":
            assert row.parents[0] in row.children or tracks.loc[row.parents[0], "end"] == "coalescence"


def test_main_branch_keeps_the_id_of_a_granule_that_sheds_a_pair():
    big, ids = range(10), np.arange(30)
    f0 = frame([big], ids)
    # it sheds the pair {8, 9} and layers particle 25; a pair {20, 21} is born and dies
    f1 = frame([[20, 21], [*range(8), 25], [8, 9]], ids)
    f2 = frame([[*range(8), 25], [8, 9]], ids)
    strict = track([f0, f1, f2])
    main = track([f0, f1, f2], continuation="main")
    check_same_events(strict, main)
    assert strict.event_counts().to_dict() == {"birth": 1, "death": 1, "coalescence": 0, "breakage": 1}

    assert track_of(strict, 1, 1) != track_of(strict, 0, 0)  # strict: the large piece is a new track
    assert track_of(main, 1, 1) == track_of(main, 0, 0) == track_of(main, 2, 0)
    shed = track_of(main, 1, 2)
    assert shed != track_of(main, 0, 0) and shed == track_of(main, 2, 1)
    brk = events_of(main, "breakage").iloc[0]
    assert brk["parents"] == [track_of(main, 0, 0)] and brk["children"] == [track_of(main, 0, 0), shed]
    tracks = main.tracks.set_index("track")
    assert tracks.loc[track_of(main, 0, 0), ["origin", "end", "sizes"]].tolist() == ["initial", "alive", [10, 9, 9]]
    assert tracks.loc[shed, ["origin", "end", "sizes"]].tolist() == ["breakage", "alive", [2, 2]]
    assert main.n_tracks == 3 and strict.n_tracks == 4
    check_main_tracks(main)


def test_main_branch_continues_the_largest_contributor_of_a_coalescence():
    A, B, C = range(6), range(6, 10), range(10, 13)
    ids = np.arange(20)
    f0 = frame([B, A, C], ids)  # the largest contributor is not label 0
    f1 = frame([[*A, *B, 10, 11, 15]], ids)  # A + B + two of C (a third coalescing parent) + a free particle
    strict = track([f0, f1])
    main = track([f0, f1], continuation="main")
    check_same_events(strict, main)
    coal = events_of(main, "coalescence").iloc[0]
    assert coal["parent_sizes"] == [4, 6, 3] and coal["children"] == [track_of(main, 0, 1)]
    tracks = main.tracks.set_index("track")
    assert tracks.loc[track_of(main, 0, 1), ["end", "sizes"]].tolist() == ["alive", [6, 13]]
    assert [tracks.loc[track_of(main, 0, g), "end"] for g in (0, 2)] == ["coalescence", "coalescence"]
    assert track_of(strict, 1, 0) not in [track_of(strict, 0, g) for g in range(3)]
    check_main_tracks(main)


def test_main_branch_ties_go_to_the_larger_granule_then_to_the_smaller_particle_id():
    ids = np.arange(20)
    rng = np.random.default_rng(3)
    # a 4-particle granule breaks into two pairs: the pair holding particle 0 keeps the id,
    # whatever the labels and the row order
    for pieces in ([[0, 1], [2, 3]], [[2, 3], [0, 1]]):
        main = track([frame([range(4)], ids, rng), frame(pieces, ids, rng)], continuation="main")
        keeper = pieces.index([0, 1])
        assert track_of(main, 1, keeper) == track_of(main, 0, 0) != track_of(main, 1, 1 - keeper)
    # equal shares, one child grew: the larger child keeps the id although it holds larger ids
    main = track([frame([range(4)], ids), frame([[0, 1], [2, 3, 10, 11]], ids)], continuation="main")
    assert track_of(main, 1, 1) == track_of(main, 0, 0)
    # two pairs merge: the parent holding particle 0 continues, whatever the labels
    for pairs in ([[0, 1], [2, 3]], [[2, 3], [0, 1]]):
        main = track([frame(pairs, ids, rng), frame([range(4)], ids, rng)], continuation="main")
        assert track_of(main, 1, 0) == track_of(main, 0, pairs.index([0, 1]))
    # equal contributions, one parent larger (it lost a particle to the free ones): it continues
    main = track([frame([[0, 1], [2, 3, 4]], ids), frame([range(4)], ids)], continuation="main")
    assert track_of(main, 1, 0) == track_of(main, 0, 1)


def test_main_branch_is_the_same_for_permuted_rows_and_labels_and_keeps_the_events():
    labels, ids = random_series()
    times = np.linspace(0.0, 1.4, len(labels))
    strict = track_granules(labels, ids, times)
    main = track_granules(labels, ids, times, continuation="main")
    check_same_events(strict, main)
    check_main_tracks(main)
    assert main.n_tracks < strict.n_tracks
    assert (main.tracks["last_frame"] > main.tracks["first_frame"]).mean() > (
        strict.tracks["last_frame"] > strict.tracks["first_frame"]).mean()
    # rows permuted: the same ids; label values permuted too: the same particles share an id
    rng = np.random.default_rng(7)
    orders = [rng.permutation(lab.size) for lab in labels]
    renames = [rng.permutation(lab.max() + 1) for lab in labels]
    rows = track_granules([lab[o] for lab, o in zip(labels, orders)], [i[o] for i, o in zip(ids, orders)], times,
                          continuation="main")
    for a, b in zip(main.labels_to_tracks, rows.labels_to_tracks):
        assert np.array_equal(a, b)
    renamed = [np.where(lab >= 0, r[np.maximum(lab, 0)], -1) for lab, r in zip(labels, renames)]
    relabelled = track_granules(renamed, ids, times, continuation="main")

    def members(tr, labs):  # each track as the set of (frame, particle id) it holds
        out = {}
        for k, (lab, pid) in enumerate(zip(labs, ids)):
            for t, p in zip(tr.labels_to_tracks[k][lab[lab >= 0]], pid[lab >= 0]):
                out.setdefault(int(t), set()).add((k, int(p)))
        return sorted(map(sorted, out.values()))

    assert members(main, labels) == members(relabelled, renamed)


def test_invalid_continuation_is_one_line_naming_it():
    lab, ids = np.array([0, 0, -1]), np.arange(3)
    for bad in ("branch", None, 1):
        with pytest.raises(ParameterError, match=r"^track_granules: continuation must be one of 'main', 'strict', got ") as info:
            track_granules([lab, lab], [ids, ids], [0, 1], continuation=bad)
        assert "\n" not in str(info.value)
    snaps = [synthetic_snapshot(50, time=0.1 * k, seed=k) for k in range(2)]
    with pytest.raises(ParameterError, match="continuation"):
        track_run(snaps, continuation="Main")


# ----------------------------------------------------------------------------------------------
# consistency with identification


def test_sizes_match_identification_and_row_order_does_not_matter():
    params = dict(method="gna", c_agg=0.6, a_agg_deg=20, cohesion="acting")
    snaps = [synthetic_snapshot(500, time=0.1 * k, seed=10 + k) for k in range(3)]
    tr = track_run(snaps, **params)
    assert list(tr.frame_indices) == [0, 1, 2]
    tracks = tr.tracks.set_index("track")
    for k, snap in enumerate(snaps):
        result = ga.identify(snap, **params)
        assert np.array_equal(tr.sizes_by_frame[k], result.sizes)
        for g, size in enumerate(result.sizes):
            row = tracks.loc[tr.labels_to_tracks[k][g]]
            assert row.sizes[k - row.first_frame] == size
    check_consistency(tr)
    # shuffled rows: the same granules (labels of equal-size granules may swap, and so track ids)
    rng = np.random.default_rng(0)
    shuffled = track_run([s.take_particles(rng.permutation(s.n_particles)) for s in snaps], **params)
    for table in ("events", "tracks"):
        a, b = getattr(tr, table), getattr(shuffled, table)
        key = (["kind", "frame", "n_particles", "parent_sizes", "child_sizes"] if table == "events"
               else ["origin", "end", "first_frame", "last_frame", "sizes"])
        summary = [sorted(zip(*(x[c].astype(str) for c in key))) for x in (a, b)]
        assert summary[0] == summary[1]
    assert tr.event_counts().to_dict() == shuffled.event_counts().to_dict()


# ----------------------------------------------------------------------------------------------
# rates on a planted series with known counts


@pytest.fixture
def planted():
    """t = 0..4 s: A(2)+B(2) coalesce; AB(4) breaks into 2+2; one half (2) coalesces with C(4)."""
    ids = np.arange(20)
    C = [10, 11, 12, 13]
    frames = [
        frame([[0, 1], [2, 3], C], ids),
        frame([[0, 1, 2, 3], C], ids),
        frame([[0, 1], [2, 3], C], ids),
        frame([[0, 1, *C], [2, 3]], ids),
        frame([[0, 1, *C], [2, 3]], ids),
    ]
    return track(frames, times=np.arange(5.0))


def test_event_rates_per_revolution_and_per_second(planted):
    assert planted.event_counts().to_dict() == {"birth": 0, "death": 0, "coalescence": 2, "breakage": 1}
    rates = event_rates(planted, revolution_period_s=2.0)
    assert len(rates) == 2 * len(KINDS)
    assert rates["rev_start"].unique().tolist() == [0.0, 1.0] and rates["observed_s"].unique().tolist() == [2.0]
    counts = rates.pivot(index="bin", columns="kind", values="count")
    assert counts["coalescence"].tolist() == [1, 1] and counts["breakage"].tolist() == [1, 0]
    assert counts["birth"].sum() == counts["death"].sum() == 0
    per_rev = rates.pivot(index="bin", columns="kind", values="rate_per_rev")
    assert per_rev["coalescence"].tolist() == [1.0, 1.0]
    per_s = rates.pivot(index="bin", columns="kind", values="rate_per_s")
    assert per_s["breakage"].tolist() == [0.5, 0.0]
    plain = event_rates(planted, bin_width=4.0)
    assert len(plain) == len(KINDS) and plain["rate_per_rev"].isna().all()
    assert plain.set_index("kind").loc["coalescence", "rate_per_s"] == 0.5
    assert event_rates(planted)["count"].sum() == 3  # default: ten bins in seconds


def test_coalescence_kernel_and_breakage_rate(planted):
    # classes {2, 3} and {4..7}; frames 0..3 (1 s each) hold class-0/1 counts 2/1, 0/2, 2/1, 1/1
    kernel = coalescence_kernel(planted, size_bins=[2, 4, 8]).set_index(["class_i", "class_j"])
    assert kernel["n_mean_i"].tolist() == [1.25, 1.25, 1.25] and kernel["n_mean_j"].tolist()[2] == 1.25
    assert kernel["n_events"].tolist() == [1, 1, 0]
    assert kernel.loc[(0, 0), "rate_per_s"] == pytest.approx(0.25)
    assert kernel.loc[(0, 0), "beta_per_s"] == pytest.approx(0.25 / (1.25**2 / 2))
    assert kernel.loc[(0, 1), "beta_per_s"] == pytest.approx(0.25 / 1.25**2)
    assert kernel.loc[(1, 1), "beta_per_s"] == 0.0
    assert kernel.loc[(0, 1), ["size_min_i", "size_max_i", "size_min_j", "size_max_j"]].tolist() == [2, 3, 4, 7]
    s = breakage_rate(planted, size_bins=[2, 4, 8]).set_index("class")
    assert s["n_events"].tolist() == [0, 1] and s.loc[1, "fragments_mean"] == 2.0
    assert s.loc[1, "selection_rate_per_s"] == pytest.approx(0.25 / 1.25) and s.loc[0, "selection_rate_per_s"] == 0
    default = coalescence_kernel(planted)  # logarithmic classes from the data
    assert default["n_events"].sum() == 2 and default["size_min_i"].min() == 2
    assert breakage_rate(planted)["n_events"].sum() == 1


def test_kernel_weights_a_three_parent_coalescence_as_two_binary_events():
    ids = np.arange(20)
    tr = track([frame([[0, 1], [2, 3], [4, 5, 6, 7]], ids), frame([range(8)], ids)])
    kernel = coalescence_kernel(tr, size_bins=[2, 4, 8]).set_index(["class_i", "class_j"])
    assert kernel["n_pairs"].tolist() == [1, 2, 0] and kernel["n_events"].tolist() == [1, 1, 0]
    assert kernel["n_binary"].sum() == pytest.approx(2.0)
    assert kernel.loc[(0, 1), "n_binary"] == pytest.approx(4 / 3)


def test_rate_errors_are_poisson_over_the_tracked_time(planted):
    rates = event_rates(planted, revolution_period_s=2.0).set_index(["bin", "kind"])
    per_rev = rate_errors(rates)
    assert per_rev[(0, "coalescence")] == 1.0 and per_rev[(0, "breakage")] == 1.0  # one event: ± the rate
    assert per_rev[(1, "breakage")] == 0 and per_rev[(0, "birth")] == 0  # no event: no error
    assert rate_errors(rates, "rate_per_s")[(0, "coalescence")] == 0.5
    one_bin = event_rates(planted, bin_width=4.0).set_index("kind")  # two coalescences in 4 s
    assert rate_errors(one_bin, "rate_per_s")["coalescence"] == pytest.approx(math.sqrt(2) / 4)
    with pytest.raises(ParameterError, match="rate_errors: column must be one of 'rate_per_rev', 'rate_per_s', got str 'count'"):
        rate_errors(one_bin, "count")


def test_kernel_matrix_is_symmetric_and_labelled_by_the_classes(planted):
    kernel = coalescence_kernel(planted, size_bins=[2, 4, 8])
    counts = kernel_matrix(kernel, "n_events")
    assert list(counts.index) == list(counts.columns) == ["2–3", "4–7"]
    assert counts.to_numpy().tolist() == [[1, 1], [1, 0]]  # A+B within class 0; a fragment (2) with C (4) across
    beta = kernel_matrix(kernel)
    assert beta.iloc[0, 1] == beta.iloc[1, 0] == kernel.set_index(["class_i", "class_j"]).loc[(0, 1), "beta_per_s"]
    original = kernel_matrix(coalescence_kernel(planted, size_bins=[2, 4, 8], size_unit="original", alpha=2))
    assert list(original.index) == ["16–24", "32–56"]
    with pytest.raises(ParameterError, match="column must be a column of the kernel"):
        kernel_matrix(kernel, "beta")


def test_size_histories_are_the_longest_lived_tracks_the_largest_first(planted):
    histories = size_histories(planted, 3)
    sizes = sorted(tuple(part["size"]) for _, part in histories.groupby("track"))
    assert sizes == [(2, 2, 2), (4, 4, 4), (6, 6)]  # a fragment of AB and C live 3 frames, C with a fragment 2
    assert histories.attrs["size_unit"] == "particles" and list(histories["track"]) == sorted(histories["track"])
    longest = size_histories(planted, 1)  # of the two that live 3 frames, the larger: C
    assert longest["size"].tolist() == [4, 4, 4] and longest["time_s"].tolist() == [0.0, 1.0, 2.0]
    assert longest["origin"].iloc[0] == "initial" and longest["end"].iloc[0] == "coalescence"
    assert size_histories(planted, 1, size_unit="original", alpha=2)["size"].tolist() == [32, 32, 32]
    assert size_histories(planted, 0).empty
    with pytest.raises(ParameterError, match="size_histories: size_unit='original' needs the CG factor"):
        size_histories(planted, size_unit="original")
    with pytest.raises(ParameterError, match="size_histories: n must be a whole number >= 0, got int -1"):
        size_histories(planted, -1)


def test_tracking_figure(planted):
    import matplotlib.pyplot as plt

    rates = event_rates(planted, revolution_period_s=2.0)
    fig = tracking_figure(planted, rates, coalescence_kernel(planted, size_bins=[2, 4, 8]))
    try:
        assert len(fig.axes) == 4  # rates, histories, kernel and its colour bar
        assert {t.get_text() for t in fig.axes[2].texts} == {"0", "1"}
    finally:
        plt.close(fig)
    fig = tracking_figure(planted, event_rates(planted))
    assert len(fig.axes) == 2
    plt.close(fig)


# ----------------------------------------------------------------------------------------------
# command line


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("track") / "run.h5"
    return write_synthetic_run(path, n_particles=300, revolutions=1.0, frames_per_revolution=4, seed=4)


def parse(argv):
    parser = argparse.ArgumentParser(prog="granalytics")
    add_track_parser(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)


def test_cli_writes_consistent_tables_and_refuses_to_overwrite(run_file, tmp_path, capsys):
    out = tmp_path / "tracks"
    args = parse(["track", run_file, "--out", str(out), "--c-agg", "0.6", "--cohesion", "acting", "--quiet"])
    assert args.func(args) == 0
    assert "wrote 6 files" in capsys.readouterr().out
    events = pd.read_csv(out / "events.csv")
    tracks = pd.read_csv(out / "tracks.csv")
    rates = pd.read_csv(out / "rates.csv")
    kernel = pd.read_csv(out / "kernel.csv")
    breakage = pd.read_csv(out / "breakage.csv")
    assert (out / "tracking.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert list(events.columns[:6]) == ["time_s", "frame", "kind", "parents", "children", "n_particles"]
    assert set(events["kind"]) <= set(KINDS) and len(events) > 0
    sizes = tracks["sizes"].map(json.loads)
    assert (sizes.map(len) == tracks["last_frame"] - tracks["first_frame"] + 1).all()
    assert set(tracks["first_frame"]) <= set(range(5)) and tracks["track"].tolist() == list(range(len(tracks)))
    referenced = {t for col in ("parents", "children") for lst in events[col].map(json.loads) for t in lst}
    assert referenced <= set(tracks["track"])
    assert rates.groupby("kind")["count"].sum().to_dict() == events["kind"].value_counts().reindex(list(KINDS), fill_value=0).to_dict()
    assert rates["rev_end"].max() == 1.0
    n_coal = (events["kind"] == "coalescence").sum()
    assert kernel["n_events"].sum() >= n_coal and breakage["n_events"].sum() == (events["kind"] == "breakage").sum()

    with pytest.raises(ParameterError, match="--overwrite"):
        args.func(args)
    again = parse(["track", run_file, "--out", str(out), "--window-rev", "0.2:1", "--min-fragment", "3", "--overwrite",
                   "--quiet"])
    assert again.func(again) == 0
    assert pd.read_csv(out / "tracks.csv")["first_frame"].max() <= 3  # 4 frames in the window
    bad = parse(["track", run_file, "--out", str(out), "--min-fragment", "0", "--overwrite", "--quiet"])
    with pytest.raises(ParameterError, match="min-fragment"):
        bad.func(bad)
    short = parse(["track", run_file, "--out", str(tmp_path / "x"), "--window-rev", "0.9:1", "--quiet"])
    with pytest.raises(ParameterError, match="at least two frames"):
        short.func(short)


# ----------------------------------------------------------------------------------------------
# size: 60 frames of 20 000 particles of random labels (no timing threshold: it must just finish)


def test_large_random_series_completes():
    rng = np.random.default_rng(7)
    n, n_frames = 20_000, 60
    labels = [rng.integers(-1, 1500, n) for _ in range(n_frames)]
    ids = [rng.permutation(n) for _ in range(n_frames)]
    tr = track_granules(labels, ids, np.arange(n_frames) * 0.05)
    assert tr.n_frames == n_frames and len(tr.labels_to_tracks) == n_frames
    assert sum(len(s) for s in tr.tracks["sizes"]) == sum(int((s > 0).sum()) for s in tr.sizes_by_frame)
    assert math.isfinite(event_rates(tr, 1.0)["rate_per_rev"].sum())
