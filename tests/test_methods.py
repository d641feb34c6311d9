"""DBSCAN, virtual sieving and community detection on hand-built frames."""

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import granalytics as ga
from granalytics import ParameterError
from granalytics.identification import sieve_analysis
from granalytics.datasets.synthetic import synthetic_snapshot
from granalytics.identification.kernels import canonical_labels
from conftest import R0, make_meta, make_snapshot

D = 2 * R0


def line(xs, **kw):
    pos = np.column_stack([np.asarray(xs, float), np.zeros(len(xs)), np.zeros(len(xs))])
    return make_snapshot(len(xs), kw.pop("pairs", []), position=pos, **kw)


def test_dbscan_eps_is_in_mean_diameters_and_cg_invariant():
    s = line([0, 1.0 * D, 2.05 * D, 3.5 * D, 4.4 * D, 9 * D])
    assert ga.identify(s, method="dbscan", bridged_only=False, eps_diameters=1.1).labels.tolist() == [0, 0, 0, 1, 1, -1]
    assert ga.identify(s, method="dbscan", bridged_only=False, eps_diameters=1.5).labels.tolist() == [0, 0, 0, 0, 0, -1]
    big = dataclasses.replace(s, position=s.position * 3, radius=s.radius * 3, meta=make_meta(6, alpha=3.0))
    assert ga.identify(big, method="dbscan", bridged_only=False, eps_diameters=1.1).labels.tolist() == [0, 0, 0, 1, 1, -1]


def test_dbscan_with_min_samples_2_equals_components_of_the_eps_graph():
    s = synthetic_snapshot(800, seed=9)
    x = s.position / (2 * s.meta.mean_radius)
    d = np.linalg.norm(x[:, None] - x[None], axis=2)
    i, j = np.nonzero(np.triu(d <= 1.05, 1))
    _, comp = connected_components(coo_matrix((np.ones(i.size), (i, j)), shape=(800, 800)), directed=False)
    expected = ga.identify(s, method="gna", c_agg=0.0, a_agg_deg=180.0)  # placeholder type for partition()
    expected.labels, expected.sizes = canonical_labels(comp.astype(np.int64))
    got = ga.identify(s, method="dbscan", bridged_only=False, eps_diameters=1.05)
    assert got.partition() == expected.partition() and got.n_granules > 0


def test_dbscan_bridged_only_and_velocity_features():
    # 0-1 touching with a bridge, 1-2 touching without
    s = line([0, D, 2 * D], pairs=[(0, 1), (1, 2)], bridge_volume=np.array([1e-12, 0.0]))
    bridged = dict(method="dbscan", eps_diameters=1.1, bridged_only=True)
    assert ga.identify(s, **bridged).labels.tolist() == [0, 0, -1]
    # touching: the bridge exerts no force in a run without capillary force in contact
    touching = dataclasses.replace(s, gap=np.array([-1e-6, -1e-6]))
    assert ga.identify(touching, **bridged, cohesion="bridge").labels.tolist() == [0, 0, -1]
    assert ga.identify(touching, **bridged).labels.tolist() == [-1, -1, -1]
    assert ga.identify(s, method="dbscan", bridged_only=False, eps_diameters=1.1).labels.tolist() == [0, 0, 0]
    # same places, particle 2 moving the other way: velocity features separate it
    v = np.array([[1.0, 0, 0], [1.0, 0, 0], [-1.0, 0, 0]])
    s = line([0, D, 2 * D], velocity=v)
    assert ga.identify(s, method="dbscan", bridged_only=False, eps_diameters=1.1, velocity_weight=1.0).labels.tolist() == [0, 0, -1]
    with pytest.raises(ParameterError, match="eps_diameters"):
        ga.identify(s, method="dbscan", eps_diameters=0)


def test_sieve_width_is_the_second_largest_principal_extent():
    # a rod of 4 touching spheres along a diagonal: length 8R0, width 2R0; a lone sphere
    axis = np.array([1.0, 1.0, 0.0]) / math.sqrt(2)
    pos = np.vstack([k * D * axis for k in range(4)] + [[0.05, 0.05, 0.05]])
    s = make_snapshot(5, [(0, 1), (1, 2), (2, 3)], position=pos)
    r = ga.identify(s, method="sieve")
    assert r.labels.tolist() == [0, 0, 0, 0, -1]
    widths = r.extra["widths_m"][r.extra["membership"]]
    assert widths[0] == pytest.approx(D, rel=1e-9) and widths[4] == pytest.approx(D, rel=1e-9)
    # a 2x2 square of spheres: width = 2 diameters
    sq = make_snapshot(4, [(0, 1), (1, 3), (2, 3), (0, 2)], position=[[0, 0, 0], [D, 0, 0], [0, D, 0], [D, D, 0]])
    w = ga.identify(sq, method="sieve").extra["widths_m"][0]
    assert w == pytest.approx(2 * D, rel=1e-9)


def test_sieve_analysis_fractions_and_quantiles():
    widths = np.array([0.5, 1.5, 1.5, 3.0, 5.0])
    mass = np.array([1.0, 1.0, 1.0, 3.0, 4.0])
    table, q = sieve_analysis(widths, mass, apertures=[1.0, 2.0, 4.0])
    assert table.aperture_m.tolist() == [0.0, 1.0, 2.0, 4.0]
    assert table.retained_fraction.tolist() == pytest.approx([0.1, 0.2, 0.3, 0.4])
    assert table.passing_fraction.tolist() == pytest.approx([0.0, 0.1, 0.3, 0.6])
    # 50 % passes between 2 (30 %) and 4 (60 %): log-linear
    assert q["d50_m"] == pytest.approx(math.exp(math.log(2) + (0.5 - 0.3) / 0.3 * math.log(2)))
    assert q["d10_m"] == pytest.approx(1.0) and math.isnan(q["d90_m"])


def test_sieve_on_gna_edges_gives_gna_granules():
    s = synthetic_snapshot(3000, seed=2)
    a = ga.identify(s, method="gna")
    b = ga.identify(s, method="sieve", connect="gna")
    assert np.array_equal(a.labels, b.labels)
    assert b.extra["sieve"].retained_fraction.sum() == pytest.approx(1.0)
    assert b.extra["d10_m"] < b.extra["d50_m"] < b.extra["d90_m"]


def test_community_detection_splits_two_cliques_joined_by_a_weak_bond():
    a, b = range(0, 6), range(6, 12)
    pairs = list(itertools.combinations(a, 2)) + list(itertools.combinations(b, 2)) + [(5, 6)]
    f = [0.9] * (len(pairs) - 1) + [0.2]
    s = make_snapshot(13, pairs, f)
    r = ga.identify(s, method="community")
    assert r.partition() == {frozenset(a), frozenset(b)}
    assert r.labels[12] == -1
    gna = ga.identify(s, method="gna", c_agg=0.1)
    assert gna.n_granules == 1  # connectivity alone percolates
    again = ga.identify(s, method="community")
    assert np.array_equal(r.labels, again.labels)


@pytest.mark.parametrize("method", ["gna", "dbscan", "sieve", "community"])
def test_every_method_runs_through_identify_and_reports_its_parameters(method):
    s = synthetic_snapshot(500, seed=4)
    r = ga.identify(s, method=method)
    assert r.method == method and isinstance(r.params, dict) and r.labels.shape == (500,)
    assert len(r.granules) == r.n_granules


def test_the_command_line_and_the_library_run_every_method_at_the_same_meaningful_defaults(tmp_path):
    """The README's `compare-methods RUN --methods gna,dbscan,sieve,community` gives the numbers of
    ga.compare_methods with every method at its defaults, and those defaults are meaningful on a
    wet drum bed: the sieve sieves GNA's granules, community splits them, DBSCAN is not one lump."""
    import pandas as pd

    from granalytics.cli import main
    from granalytics.datasets import dataset_path

    path = str(dataset_path("lab-cg3"))
    out = tmp_path / "stats.csv"
    assert main(["compare-methods", path, "--methods", "gna,dbscan,sieve,community", "--window-rev", "3:3.25",
                 "--stats-out", str(out), "--quiet"]) == 0
    cli = pd.read_csv(out)
    with ga.open_run(path) as run:
        api, _ = ga.compare_methods(run.select(revolutions=(3, 3.25)),
                                    {m: (m, {}) for m in ("gna", "dbscan", "sieve", "community")})
    for column in ("yield_fraction", "n_granules_norm", "mean_volume_norm"):
        np.testing.assert_allclose(cli[column].to_numpy(), api[column].to_numpy(), rtol=1e-12)
    mean = api.groupby("method")["yield_fraction"].mean()
    assert mean["sieve"] == mean["gna"] and mean["community"] == pytest.approx(mean["gna"], abs=0.02)
    assert 0.5 * mean["gna"] < mean["dbscan"] < 0.9  # not the whole bed


def test_a_parameter_assigned_after_a_first_identify_is_checked_at_the_next():
    """The check of an identifier's parameters is skipped while they stay the same objects (it ran
    several times per frame); one assigned since is checked again."""
    frame = synthetic_snapshot(60, seed=3)
    gna = ga.GraphNetworkAnalysis()
    gna.identify(frame)
    gna.c_agg = -1.0
    with pytest.raises(ParameterError, match=r"^GraphNetworkAnalysis: c_agg must be"):
        gna.identify(frame)
    gna.c_agg = 0.5
    assert gna.identify(frame).params["c_agg"] == 0.5


def test_compare_methods_and_identical_methods_refuse_their_arguments_at_the_door():
    frames = [synthetic_snapshot(30, seed=1)]
    for methods in ({"gna": ("gna", {})}, {"a": "gna", "b": "dbscan"}):
        with pytest.raises(ParameterError, match=r"^compare_methods: methods must map two or more display names"):
            ga.compare_methods(frames, methods)
    with pytest.raises(ParameterError, match=r"^compare_methods: methods must be a dict .*, got list"):
        ga.compare_methods(frames, ["gna", "dbscan"])
    with pytest.raises(ParameterError, match=r"^identical_methods: stats must be compare_methods' statistics table"):
        ga.identical_methods({"method": ["gna"]})
