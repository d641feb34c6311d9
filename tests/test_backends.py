"""All graph backends give identical labels (hypothesis property test)."""

import networkx as nx
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import granalytics as ga
from granalytics.identification import kernels as _kernels
from granalytics.identification import BACKENDS
from conftest import make_snapshot

DIRECTIONS = np.array([[1, 0, 0], [0, 1, 0], [1, 0.1, 0], [-1, 0, 0], [0, 0, 0], [0.7, 0.7, 0]], dtype=float)


@st.composite
def random_frames(draw):
    n = draw(st.integers(1, 40))
    possible = [(i, j) for i in range(n) for j in range(i + 1, n)]
    pairs = draw(st.lists(st.sampled_from(possible), unique=True, max_size=80)) if possible else []
    f_norm = draw(st.lists(st.sampled_from([0.0, 0.3, 0.6, 0.9, 1.2]), min_size=len(pairs), max_size=len(pairs)))
    v = draw(st.lists(st.integers(0, len(DIRECTIONS) - 1), min_size=n, max_size=n))
    w = draw(st.lists(st.integers(0, len(DIRECTIONS) - 1), min_size=n, max_size=n))
    radius = draw(st.lists(st.sampled_from([0.6e-3, 0.75e-3, 0.9e-3]), min_size=n, max_size=n))
    return make_snapshot(n, pairs, f_norm, radius=radius, velocity=DIRECTIONS[v], angular_velocity=DIRECTIONS[w])


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(snapshot=random_frames(), c_agg=st.sampled_from([0.0, 0.5, 0.6, 1.0]), a_agg=st.sampled_from([10.0, 20.0, 90.0, 180.0]))
def test_every_backend_gives_the_same_partition_and_labels(snapshot, c_agg, a_agg):
    results = {b: ga.identify(snapshot, c_agg=c_agg, a_agg_deg=a_agg, backend=b) for b in BACKENDS}
    ref = results["networkx"]
    for backend, result in results.items():
        assert np.array_equal(result.labels, ref.labels), backend
        assert np.array_equal(result.sizes, ref.sizes), backend
        assert np.array_equal(result.kept, ref.kept), backend
    # and the partition equals plain BFS components of the kept contacts
    graph = nx.Graph()
    graph.add_nodes_from(range(snapshot.n_particles))
    graph.add_edges_from(zip(snapshot.contact_i[ref.kept], snapshot.contact_j[ref.kept]))
    expected = {frozenset(c) for c in nx.connected_components(graph) if len(c) >= 2}
    assert ref.partition() == expected


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 29), st.integers(0, 29)), max_size=60))
def test_union_find_equals_networkx_components(edges):
    n = 30
    ei = np.array([e[0] for e in edges], dtype=np.int64)
    ej = np.array([e[1] for e in edges], dtype=np.int64)
    membership = _kernels.union_find_membership(n, ei, ej)
    graph = nx.Graph()
    graph.add_nodes_from(range(n))
    graph.add_edges_from(edges)
    for component in nx.connected_components(graph):
        assert len({membership[i] for i in component}) == 1
    assert len(set(membership.tolist())) == nx.number_connected_components(graph)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 24), min_size=1, max_size=25))
def test_canonical_labels_number_granules_by_size_then_smallest_member(ids):
    membership = np.array(ids, dtype=np.int64) % len(ids)
    labels, sizes = _kernels.canonical_labels(membership)
    groups = {}
    for i, c in enumerate(membership.tolist()):
        groups.setdefault(c, []).append(i)
    granules = sorted((g for g in groups.values() if len(g) >= 2), key=lambda g: (-len(g), g[0]))
    expected = np.full(len(ids), -1)
    for rank, members in enumerate(granules):
        expected[members] = rank
    assert np.array_equal(labels, expected)
    assert sizes.tolist() == [len(g) for g in granules]
