"""Graph network analysis: the two criteria of §2.2, the radius choice, zero vectors, CG scaling."""

import dataclasses
import math

import numpy as np
import pytest

import granalytics as ga
from granalytics import GraphNetworkAnalysis, ParameterError, Snapshot
from granalytics.datasets.synthetic import synthetic_snapshot
from conftest import GAMMA, make_meta, make_snapshot


def kept(snapshot, **params):
    return ga.identify(snapshot, **params).kept


def rotated(deg):
    a = math.radians(deg)
    return [math.cos(a), math.sin(a), 0.0]


def test_defaults_are_the_papers():
    g = GraphNetworkAnalysis()
    assert g.c_agg == 0.6 and g.a_agg_deg == 20.0 and g.radius == "pair" and g.backend == "fast"


@pytest.mark.parametrize("f_norm, expected", [(0.6 * (1 + 1e-9), True), (0.6 * (1 - 1e-9), False), (0.95, True), (0.0, False)])
def test_cohesion_criterion_is_f_cap_at_least_c_agg_times_2_pi_gamma_r(f_norm, expected):
    s = make_snapshot(2, [(0, 1)], [f_norm])
    assert kept(s, c_agg=0.6).tolist() == [expected]
    assert (ga.identify(s, c_agg=0.6).labels.tolist() == [0, 0]) == expected


def test_pair_radius_is_the_effective_radius_and_mean_radius_is_an_option():
    radius = np.array([0.5e-3, 1.0e-3])
    r_star = 2 * 0.5e-3 * 1.0e-3 / 1.5e-3
    meta = make_meta(2, mean_radius=0.75e-3)
    s = make_snapshot(2, [(0, 1)], [0.62], radius=radius, meta=meta)  # F = 0.62·2πγR*
    assert s.f_cap[0] == pytest.approx(0.62 * 2 * math.pi * GAMMA * r_star)
    assert kept(s, c_agg=0.6, radius="pair").tolist() == [True]
    # with the mean radius 0.75 mm, F/(2πγR̄) = 0.62·R*/R̄ = 0.551 < 0.6
    assert kept(s, c_agg=0.6, radius="mean").tolist() == [False]
    assert kept(s, c_agg=0.55, radius="mean").tolist() == [True]


@pytest.mark.parametrize(
    "v_deg, w_deg, a_agg, expected",
    [
        (15, 90, 20, True),    # velocities co-moving
        (25, 90, 20, False),   # neither
        (25, 10, 20, True),    # angular velocities co-rotating: the criterion is an OR
        (15, 90, 10, False),
        (179, 179, 180, True),
        (180, 180, 180, False),  # antiparallel: angle 180 is not < 180
        (100, 100, 120, True),
        (130, 130, 120, False),
    ],
)
def test_angle_criterion_velocity_or_angular_velocity(v_deg, w_deg, a_agg, expected):
    s = make_snapshot(2, [(0, 1)], [1.0], velocity=[rotated(0), rotated(v_deg)],
                      angular_velocity=[rotated(0), rotated(w_deg)])
    assert kept(s, a_agg_deg=a_agg).tolist() == [expected]


def test_a_zero_vector_never_satisfies_an_angle():
    still = [0.0, 0.0, 0.0]
    # v zero for one particle, ω co-rotating: kept through ω
    s = make_snapshot(2, [(0, 1)], [1.0], velocity=[still, rotated(0)], angular_velocity=[rotated(0), rotated(5)])
    assert kept(s).tolist() == [True]
    # v and ω zero for both particles: no direction, not kept, even with A_agg = 180°
    s = make_snapshot(2, [(0, 1)], [1.0], velocity=[still, still], angular_velocity=[still, still])
    assert kept(s, a_agg_deg=180).tolist() == [False]


def reference_mask(s, c_agg, a_agg_deg, gamma):
    """The criteria written out plainly with arccos."""
    ri, rj = s.radius[s.contact_i], s.radius[s.contact_j]
    f = s.f_cap / (2 * np.pi * gamma * 2 * ri * rj / (ri + rj))

    def angle(a, b):
        na, nb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ang = np.degrees(np.arccos(np.clip((a * b).sum(1) / (na * nb), -1, 1)))
        return np.where((na == 0) | (nb == 0), np.inf, ang)

    av = angle(s.velocity[s.contact_i], s.velocity[s.contact_j])
    aw = angle(s.angular_velocity[s.contact_i], s.angular_velocity[s.contact_j])
    return (f >= c_agg) & ((av < a_agg_deg) | (aw < a_agg_deg)), f, av, aw


@pytest.mark.parametrize("a_agg", [5.0, 20.0, 45.0, 90.0, 135.0])
def test_kernel_matches_plain_arccos_reference(a_agg):
    s = synthetic_snapshot(3000, seed=11)
    ref, f, av, aw = reference_mask(s, 0.6, a_agg, s.meta.surface_tension)
    fast = kept(s, a_agg_deg=a_agg)
    differ = fast != ref
    near = (np.abs(f - 0.6) < 1e-12) | (np.abs(av - a_agg) < 1e-6) | (np.abs(aw - a_agg) < 1e-6)
    assert not (differ & ~near).any()
    assert 0.05 < ref.mean() < 0.95  # the data exercise both outcomes


def scaled(s, alpha, force_exponent=2):
    meta = make_meta(s.n_particles, alpha=alpha)
    return dataclasses.replace(
        s, radius=s.radius * alpha, position=s.position * alpha, f_cap=s.f_cap * alpha**force_exponent,
        gap=s.gap * alpha, film_volume=s.film_volume * alpha**3, bridge_volume=s.bridge_volume * alpha**3,
        meta=meta,
    )


def test_cg_scaling_f_agg_scales_as_alpha_squared_automatically():
    base = synthetic_snapshot(3000, seed=5)
    reference = ga.identify(base)
    for alpha in (2.0, 3.0):
        cg = scaled(base, alpha)
        assert cg.meta.surface_tension == pytest.approx(alpha * base.meta.surface_tension)
        result = ga.identify(cg)
        assert np.array_equal(result.labels, reference.labels)
        # forces scaled by α only (not α²) would fall below the α²-scaled threshold
        assert ga.identify(scaled(base, alpha, force_exponent=1)).n_granulated < reference.n_granulated


def test_labels_are_numbered_by_size_then_smallest_index():
    # granules {0,1}, {2,3,4}, {5,6}; 7 free
    s = make_snapshot(8, [(0, 1), (2, 3), (3, 4), (5, 6)])
    r = ga.identify(s)
    assert r.labels.tolist() == [1, 1, 0, 0, 0, 2, 2, -1]
    assert r.sizes.tolist() == [3, 2, 2] and r.n_granules == 3 and r.n_granulated == 7
    assert r.partition() == {frozenset({0, 1}), frozenset({2, 3, 4}), frozenset({5, 6})}


def test_surface_tension_comes_from_meta_or_argument():
    s = make_snapshot(2, [(0, 1)], [0.7])
    bare = Snapshot(**{f.name: getattr(s, f.name) for f in dataclasses.fields(s) if f.name != "meta"})
    with pytest.raises(ParameterError, match="surface_tension"):
        ga.identify(bare)
    assert ga.identify(bare, surface_tension=GAMMA).n_granules == 1
    assert ga.identify(bare, surface_tension=GAMMA * 2).n_granules == 0  # F/(2π·2γR) = 0.35


@pytest.mark.parametrize(
    "params, words",
    [
        ({"c_agg": -0.1}, "c_agg"),
        ({"c_agg": float("nan")}, "c_agg"),
        ({"a_agg_deg": 0}, "a_agg_deg"),
        ({"a_agg_deg": 181}, "a_agg_deg"),
        ({"radius": "max"}, "radius"),
        ({"backend": "cugraph"}, "backend"),
        ({"method": "magic"}, "unknown method"),
        ({"cagg": 0.5}, "unexpected keyword"),
    ],
)
def test_bad_parameters_raise_parameter_error(params, words):
    s = make_snapshot(2, [(0, 1)])
    with pytest.raises(ParameterError, match=words):
        ga.identify(s, **params)
