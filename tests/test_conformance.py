"""Conformance suite every identification method and backend must pass.

To add a method, add an entry to ``IDENTIFIERS``: a function ``strictness -> identifier`` where a
larger strictness (0…1) is a stricter criterion, and whether the method is *nested* (a stricter
criterion only splits granules). The suite checks that labels cover every particle, isolated
particles are never granules, results do not depend on particle order, and, for nested methods,
that a stricter criterion never merges granules.
"""

import dataclasses

import numpy as np
import pytest

from granalytics.identification import (BACKENDS, CommunityDetection, CustomEdges, DBSCANClustering, GraphNetworkAnalysis,
                                  VirtualSieve)
from granalytics.core.snapshot import Snapshot
from granalytics.datasets.synthetic import synthetic_snapshot

IDENTIFIERS = {
    **{
        f"gna-{backend}": (lambda strictness, backend=backend: GraphNetworkAnalysis(
            c_agg=0.3 + 0.6 * strictness, a_agg_deg=20.0, backend=backend), True)
        for backend in BACKENDS
    },
    # min_samples = 2: clusters are the components of the ε-graph, nested in ε
    "dbscan-positions+velocity": (lambda strictness: DBSCANClustering(
        eps_diameters=1.3 - 0.25 * strictness, velocity_weight=2.0), True),
    "dbscan-bridged": (lambda strictness: DBSCANClustering(eps_diameters=1.3 - 0.25 * strictness, bridged_only=True), True),
    "sieve-gna": (lambda strictness: VirtualSieve(connect="gna", c_agg=0.3 + 0.6 * strictness), True),
    # Leiden on all cohesive co-moving contacts, communities split by C_agg: nested in C_agg
    "community": (lambda strictness: CommunityDetection(c_agg=0.3 + 0.6 * strictness, a_agg_deg=20.0), True),
    # a user criterion: GNA's, written out
    "custom": (lambda strictness: CustomEdges(
        f"f_norm >= {0.3 + 0.6 * strictness!r} and (angle_v_deg < 20 or angle_w_deg < 20)"), True),
}


@pytest.fixture(params=sorted(IDENTIFIERS))
def method(request):
    return IDENTIFIERS[request.param]


@pytest.fixture
def make(method):
    return method[0]


@pytest.fixture(scope="module")
def snapshot():
    """A synthetic frame plus 20 isolated particles far from everything, moving like a granule."""
    base = synthetic_snapshot(1500, seed=21)
    k = 20
    far = base.position.max(axis=0) + 50 * base.radius.max() + np.arange(k)[:, None] * 10 * base.radius.max()
    copy_from = np.flatnonzero(base.velocity[:, 0] != 0)[:k]
    data = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    for name in ("radius", "velocity", "angular_velocity", "film_volume"):
        data[name] = np.concatenate([data[name], data[name][copy_from]])
    data["position"] = np.concatenate([base.position, far])
    data["ids"] = np.arange(base.n_particles + k) + 1000
    data["meta"] = dataclasses.replace(base.meta, n_particles=base.n_particles + k)
    return Snapshot(**data)


def test_labels_cover_all_particles_and_are_consistent(make, snapshot):
    r = make(0.5).identify(snapshot)
    assert r.labels.shape == (snapshot.n_particles,) and r.labels.dtype.kind == "i"
    assert r.labels.min() >= -1 and r.labels.max() == r.n_granules - 1
    assert np.array_equal(np.bincount(r.labels[r.labels >= 0], minlength=r.n_granules), r.sizes)
    assert (r.sizes >= 2).all() and (np.diff(r.sizes) <= 0).all()
    assert 0 < r.n_granules < snapshot.n_particles // 2  # non-trivial on this frame


def test_isolated_particles_are_never_granules(make, snapshot):
    r = make(0.0).identify(snapshot)
    assert (r.labels[-20:] == -1).all()


def test_result_does_not_depend_on_particle_order(make, snapshot):
    r = make(0.5).identify(snapshot)
    order = np.random.default_rng(0).permutation(snapshot.n_particles)
    shuffled = make(0.5).identify(snapshot.take_particles(order))
    assert shuffled.partition() == r.partition()


@pytest.mark.parametrize("loose, strict", [(0.0, 0.3), (0.3, 0.6), (0.6, 1.0)])
def test_a_stricter_criterion_never_merges_granules(method, snapshot, loose, strict):
    make, nested = method
    if not nested:
        pytest.skip("not a nested method (documented)")
    a = make(loose).identify(snapshot)
    b = make(strict).identify(snapshot)
    # every granule under the stricter criterion lies inside one granule of the looser one
    for g in range(b.n_granules):
        assert len(set(a.labels[b.labels == g].tolist())) == 1
        assert (a.labels[b.labels == g] >= 0).all()
    assert b.n_granulated <= a.n_granulated


def test_every_registered_method_keeps_the_identifier_contract():
    """The contract of granalytics.identification.Identifier, for every method of METHODS (a new method
    registered there fails here until it keeps it, and until IDENTIFIERS above covers it)."""
    import inspect

    from granalytics import COHESION_CONVENTIONS
    from granalytics.identification import DEFAULT_METHODS, METHODS, Identifier

    covered = {key.split("-")[0] for key in IDENTIFIERS}
    assert covered == set(METHODS)
    for name, cls in METHODS.items():
        assert issubclass(cls, Identifier) and cls.method == name
        params = inspect.signature(cls).parameters
        assert set(cls._parameter_constraints) == set(params), name  # every argument declares its constraints
        assert "cohesion" in params and params["cohesion"].kind is inspect.Parameter.KEYWORD_ONLY
        assert params["cohesion"].default in COHESION_CONVENTIONS
    assert set(DEFAULT_METHODS) == set(METHODS) - {"custom"}  # custom needs its criterion
    for name in DEFAULT_METHODS:
        identifier = METHODS[name](cohesion="bridge")
        assert identifier.params()["cohesion"] == "bridge"
        assert set(identifier.params()) == set(inspect.signature(METHODS[name]).parameters)
